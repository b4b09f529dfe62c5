#include "common/scene/usda_parser.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <set>

#include "common/util/error.h"

namespace lensfarm {

const UsdProperty* UsdPrimSpec::property(const std::string& propertyName) const {
  const UsdProperty* found = nullptr;
  for (const UsdProperty& p : properties)
    if (p.name == propertyName) found = &p;  // the last of a name wins
  return found;
}

UsdPrimSpec* UsdPrimSpec::child(const std::string& childName) const {
  for (const auto& c : children)
    if (c->name == childName) return c.get();
  return nullptr;
}

bool isUsdCrate(const std::string& bytes) { return bytes.compare(0, 8, "PXR-USDC") == 0; }
bool isZip(const std::string& bytes) { return bytes.compare(0, 4, std::string("PK\x03\x04", 4)) == 0; }

namespace {

const std::set<std::string> kListOps = {"prepend", "append", "add", "delete", "reorder"};
const std::set<std::string> kVariability = {"uniform", "varying", "config"};

// A recursive-descent reader of the usda grammar over the text, with line and column for errors.
class Parser {
 public:
  Parser(const std::string& text, std::string shown) : s_(text), shown_(std::move(shown)) {}

  UsdLayer layer() {
    if (isUsdCrate(s_))
      fail(
          "is a binary USD crate file (usdc): lensfarm reads USD's text format; convert it with "
          "`usdcat --flatten -o scene.usda scene.usdc` or export .usda");
    if (s_.compare(0, 5, "#usda") != 0) fail("is not a usda file: it does not begin with \"#usda 1.0\"");
    UsdLayer layer;
    layer.file = shown_;
    skipLine();
    skipSpace();
    if (peek() == '(') layer.metadata = metadataBlock();
    for (skipSpace(); !atEnd(); skipSpace()) {
      const std::string word = identifier("a prim (def, over or class)");
      layer.prims.push_back(primSpec(word, 0));
    }
    return layer;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    const size_t at = std::min(pos_, s_.size());
    const size_t lineStart = at == 0 ? 0 : s_.rfind('\n', at - 1);
    const size_t column = lineStart == std::string::npos ? at + 1 : at - lineStart;
    throw InputError(shown_, "line " + std::to_string(line_) + ", column " + std::to_string(column) + ": " + what);
  }
  // One character on, counting lines (every newline the parser passes goes through here).
  void advance() {
    if (s_[pos_] == '\n') ++line_;
    ++pos_;
  }
  bool atEnd() const { return pos_ >= s_.size(); }
  char peek(size_t ahead = 0) const { return pos_ + ahead < s_.size() ? s_[pos_ + ahead] : '\0'; }
  void skipLine() {
    while (!atEnd() && s_[pos_] != '\n') ++pos_;
  }
  // Whitespace, newlines and comments ('#' to the end of the line).
  void skipSpace() {
    while (!atEnd()) {
      const char c = s_[pos_];
      if (c == '#')
        skipLine();
      else if (std::isspace(static_cast<unsigned char>(c)) || c == ';')
        advance();
      else
        break;
    }
  }
  void expect(char c, const std::string& context) {
    skipSpace();
    if (peek() != c) fail(std::string("expected '") + c + "' " + context);
    ++pos_;
  }
  bool accept(char c) {
    skipSpace();
    if (peek() != c) return false;
    ++pos_;
    return true;
  }
  void enter() {
    if (++depth_ > kMaxUsdNesting) fail("nested more than " + std::to_string(kMaxUsdNesting) + " levels deep");
  }
  void leave() { --depth_; }

  static bool identifierChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '.' || c == '[' || c == ']';
  }
  // A word: a keyword, a type name (with [] for arrays), a property name with namespaces.
  std::string identifier(const std::string& expected) {
    skipSpace();
    const size_t start = pos_;
    if (!(std::isalpha(static_cast<unsigned char>(peek())) || peek() == '_')) fail("expected " + expected);
    while (!atEnd() && identifierChar(s_[pos_])) ++pos_;
    return s_.substr(start, pos_ - start);
  }

  std::string quoted() {
    const char q = peek();
    const bool triple = peek(1) == q && peek(2) == q;
    pos_ += triple ? 3 : 1;
    std::string out;
    for (;;) {
      if (atEnd()) fail("a string is not closed");
      const char c = s_[pos_];
      if (triple && c == q && peek(1) == q && peek(2) == q) {
        pos_ += 3;
        return out;
      }
      if (!triple && c == q) {
        ++pos_;
        return out;
      }
      if (!triple && c == '\n') fail("a string ends at the end of the line");
      if (c == '\\' && pos_ + 1 < s_.size()) {
        const char e = s_[pos_ + 1];
        out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
        pos_ += 2;
        continue;
      }
      out += c;
      advance();
    }
  }

  std::string delimited(char open, char close, const std::string& what) {
    ++pos_;
    const size_t start = pos_;
    while (!atEnd() && s_[pos_] != close && s_[pos_] != '\n') ++pos_;
    if (peek() != close)
      fail(what + " is not closed with '" + std::string(1, close) + "' (opened with '" + open + "')");
    ++pos_;
    return s_.substr(start, pos_ - start - 1);
  }

  double number() {
    const char* begin = s_.c_str() + pos_;
    char* end = nullptr;
    // inf, -inf and nan as the USD text format writes them.
    for (const auto& [word, value] : {std::pair<const char*, double>{"-inf", -std::numeric_limits<double>::infinity()},
                                      {"inf", std::numeric_limits<double>::infinity()},
                                      {"nan", std::numeric_limits<double>::quiet_NaN()}})
      if (s_.compare(pos_, std::strlen(word), word) == 0) {
        pos_ += std::strlen(word);
        return value;
      }
    const double v = std::strtod(begin, &end);
    if (end == begin) fail("expected a number");
    pos_ += size_t(end - begin);
    return v;
  }

  bool startsNumber() const {
    const char c = peek();
    return std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.' ||
           s_.compare(pos_, 3, "inf") == 0 || s_.compare(pos_, 3, "nan") == 0;
  }

  UsdValue value() {
    skipSpace();
    UsdValue v;
    const char c = peek();
    if (c == '"' || c == '\'') {
      v.kind = UsdValue::Kind::kString;
      v.text = quoted();
    } else if (c == '@') {
      v.kind = UsdValue::Kind::kAsset;
      if (s_.compare(pos_, 3, "@@@") == 0) {
        const size_t end = s_.find("@@@", pos_ + 3);
        if (end == std::string::npos) fail("an asset path is not closed with @@@");
        v.text = s_.substr(pos_ + 3, end - pos_ - 3);
        pos_ = end + 3;
      } else {
        v.text = delimited('@', '@', "an asset path");
      }
      if (peek() == '<') v.items.push_back(pathValue());  // a reference: @file@</Prim>
      skipSpace();
      if (peek() == '(') metadataBlock();  // a layer offset: (offset = 1; scale = 2), not used
    } else if (c == '<') {
      v = pathValue();
    } else if (c == '(') {
      v = sequence(')', UsdValue::Kind::kTuple);
    } else if (c == '[') {
      v = sequence(']', UsdValue::Kind::kArray);
    } else if (c == '{') {
      v.kind = UsdValue::Kind::kDictionary;
      v.entries = dictionary();
    } else if (startsNumber()) {
      v.kind = UsdValue::Kind::kNumber;
      v.number = number();
    } else {
      v.kind = UsdValue::Kind::kIdentifier;
      v.text = identifier("a value");
      if (v.text == "None") v.kind = UsdValue::Kind::kNone;
    }
    return v;
  }

  UsdValue pathValue() {
    UsdValue v;
    v.kind = UsdValue::Kind::kPath;
    v.text = delimited('<', '>', "a path");
    return v;
  }

  // (a, b, c) or [a, b, c]. An array of numbers or of numeric tuples is kept flat.
  UsdValue sequence(char close, UsdValue::Kind kind) {
    enter();
    ++pos_;
    UsdValue v;
    v.kind = kind;
    bool numeric = true;
    uint32_t arity = 0;
    for (skipSpace(); !accept(close);) {
      if (atEnd()) fail(std::string("a list is not closed with '") + close + "'");
      UsdValue item = value();
      if (kind == UsdValue::Kind::kArray && numeric) {
        const uint32_t n = item.kind == UsdValue::Kind::kNumber ? 1
                           : item.kind == UsdValue::Kind::kTuple && !item.numbers.empty() && item.items.empty()
                               ? uint32_t(item.numbers.size())
                               : 0;
        if (n == 0 || (arity != 0 && n != arity)) {
          numeric = false;
          // Back to general items: the numbers so far become values again.
          for (size_t i = 0; i + (arity ? arity : 1) <= v.numbers.size(); i += (arity ? arity : 1))
            v.items.push_back(numbersAsValue(v.numbers, i, arity ? arity : 1));
          v.numbers.clear();
          v.items.push_back(std::move(item));
        } else {
          arity = n;
          if (n == 1)
            v.numbers.push_back(item.number);
          else
            v.numbers.insert(v.numbers.end(), item.numbers.begin(), item.numbers.end());
        }
      } else if (kind == UsdValue::Kind::kTuple && item.kind == UsdValue::Kind::kNumber && v.items.empty()) {
        v.numbers.push_back(item.number);
      } else {
        if (kind == UsdValue::Kind::kTuple && !v.numbers.empty()) {
          for (double n : v.numbers) v.items.push_back(numbersAsValue({n}, 0, 1));
          v.numbers.clear();
        }
        v.items.push_back(std::move(item));
      }
      skipSpace();
      if (peek() == ',')
        ++pos_;
      else if (peek() != close)
        fail(std::string("expected ',' or '") + close + "' in a list");
    }
    if (kind == UsdValue::Kind::kArray) v.arity = numeric && !v.numbers.empty() ? arity : 0;
    leave();
    return v;
  }

  static UsdValue numbersAsValue(const std::vector<double>& numbers, size_t at, uint32_t arity) {
    UsdValue v;
    if (arity == 1) {
      v.kind = UsdValue::Kind::kNumber;
      v.number = numbers[at];
    } else {
      v.kind = UsdValue::Kind::kTuple;
      v.numbers.assign(numbers.begin() + long(at), numbers.begin() + long(at + arity));
    }
    return v;
  }

  // { type name = value ... } (typed entries, as customData).
  std::vector<UsdEntry> dictionary() {
    enter();
    ++pos_;
    std::vector<UsdEntry> out;
    for (skipSpace(); !accept('}'); skipSpace()) {
      std::string key;
      if (peek() == '"' || peek() == '\'') {
        key = quoted();
      } else {
        const std::string first = identifier("a dictionary entry");
        skipSpace();
        key = peek() == '=' ? first : (peek() == '"' || peek() == '\'') ? quoted() : identifier("an entry's name");
      }
      expect('=', "in a dictionary entry");
      out.push_back(UsdEntry{key, value()});
    }
    leave();
    return out;
  }

  // ( key = value  prepend key = value  "doc string" ... )
  std::map<std::string, UsdListOp> metadataBlock() {
    enter();
    ++pos_;
    std::map<std::string, UsdListOp> out;
    for (skipSpace(); !accept(')'); skipSpace()) {
      if (peek() == '"' || peek() == '\'') {
        out["doc"].value = value();
        continue;
      }
      std::string word = identifier("a metadata field");
      std::string op;
      if (kListOps.count(word)) op = std::exchange(word, identifier("a metadata field after " + word));
      UsdListOp entry{op, {}};
      if (accept('=')) entry.value = value();
      out[word] = std::move(entry);
    }
    leave();
    return out;
  }

  std::unique_ptr<UsdPrimSpec> primSpec(const std::string& specifier, int depth) {
    if (specifier != "def" && specifier != "over" && specifier != "class")
      fail("expected a prim (def, over or class), found \"" + specifier + "\"");
    if (depth > kMaxUsdNesting) fail("prims nested more than " + std::to_string(kMaxUsdNesting) + " levels deep");
    auto prim = std::make_unique<UsdPrimSpec>();
    prim->specifier = specifier;
    skipSpace();
    if (peek() != '"' && peek() != '\'') prim->typeName = identifier("a prim type or name");
    skipSpace();
    if (peek() != '"' && peek() != '\'') fail("expected the prim's name in quotes");
    prim->name = quoted();
    skipSpace();
    if (peek() == '(') prim->metadata = metadataBlock();
    expect('{', "to open the prim \"" + prim->name + "\"");
    for (skipSpace(); !accept('}'); skipSpace()) {
      if (atEnd()) fail("the prim \"" + prim->name + "\" is not closed with '}'");
      const std::string word = identifier("a property or a prim in \"" + prim->name + "\"");
      if (word == "def" || word == "over" || word == "class") {
        prim->children.push_back(primSpec(word, depth + 1));
      } else if (word == "variantSet") {
        prim->hasVariantSets = true;
        skipVariantSet();
      } else if (word == "reorder") {
        identifier("nameChildren or properties");
        expect('=', "after reorder");
        value();
      } else {
        prim->properties.push_back(property(word));
      }
    }
    return prim;
  }

  // variantSet "name" = { "variant" ( ... ) { body } ... }: skipped (the default variant is not
  // composed; usd_import notes it).
  void skipVariantSet() {
    skipSpace();
    quoted();
    expect('=', "after a variantSet's name");
    expect('{', "to open a variantSet");
    enter();
    int open = 1;
    while (open > 0) {
      if (atEnd()) fail("a variantSet is not closed");
      const char c = s_[pos_];
      if (c == '"' || c == '\'') {
        quoted();
        continue;
      }
      if (c == '#') {
        skipLine();
        continue;
      }
      open += c == '{';
      open -= c == '}';
      advance();
    }
    leave();
  }

  // [listop] [custom] [uniform] type[[]] name[.connect|.timeSamples] [= value] [( metadata )], or rel.
  UsdProperty property(std::string word) {
    UsdProperty p;
    if (kListOps.count(word)) word = identifier("a property after " + word);
    if (word == "custom") word = identifier("a property after custom");
    if (kVariability.count(word)) {
      p.uniform = word == "uniform";
      word = identifier("a property type after " + word);
    }
    p.typeName = word;
    std::string name = identifier("the name of a " + word + " property");
    enum { kValue, kConnect, kTimeSamples } form = kValue;
    for (const auto& [suffix, f] :
         {std::pair<const char*, decltype(form)>{".connect", kConnect}, {".timeSamples", kTimeSamples}})
      if (name.size() > std::strlen(suffix) &&
          name.compare(name.size() - std::strlen(suffix), std::string::npos, suffix) == 0) {
        name.resize(name.size() - std::strlen(suffix));
        form = f;
      }
    p.name = name;
    skipSpace();
    if (accept('=')) {
      skipSpace();
      if (form == kTimeSamples) {
        if (peek() != '{') fail("expected '{' for the time samples of " + name);
        for (auto& [time, v] : dictionaryOfTimes()) p.timeSamples.emplace_back(time, std::move(v));
      } else {
        UsdValue v = value();
        if (form == kConnect || word == "rel") {
          for (const UsdValue& target : v.kind == UsdValue::Kind::kArray ? v.items : std::vector<UsdValue>{v})
            if (target.kind == UsdValue::Kind::kPath) p.connections.push_back(target.text);
          if (word == "rel") {
            p.hasDefault = true;
            p.value = std::move(v);
          }
        } else {
          p.hasDefault = true;
          p.value = std::move(v);
        }
      }
    }
    skipSpace();
    if (peek() == '(') {
      for (auto& [key, entry] : metadataBlock()) p.metadata[key] = std::move(entry.value);
    }
    return p;
  }

  std::vector<std::pair<double, UsdValue>> dictionaryOfTimes() {
    enter();
    ++pos_;
    std::vector<std::pair<double, UsdValue>> out;
    for (skipSpace(); !accept('}'); skipSpace()) {
      const double time = number();
      expect(':', "after a time sample's time");
      out.emplace_back(time, value());
      skipSpace();
      if (peek() == ',') ++pos_;
    }
    leave();
    return out;
  }

  const std::string& s_;
  std::string shown_;
  size_t pos_ = 0;
  int line_ = 1;
  int depth_ = 0;
};

}  // namespace

UsdLayer parseUsda(const std::string& text, const std::string& shown) { return Parser(text, shown).layer(); }

}  // namespace lensfarm
