#include "common/scene/obj_check.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace lensfarm {

namespace {

constexpr std::string_view kBom = "\xEF\xBB\xBF";
constexpr std::string_view kGlTFAdvice = "give it as a glTF shape (\"type\": \"gltf\")";

bool startsWith(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

// A token for a message: printable ASCII as is, anything else as \xNN, at most 32 characters.
std::string quoted(std::string_view token) {
  std::string out = "'";
  size_t shown = 0;
  for (unsigned char c : token) {
    if (shown++ == 32) {
      out += "...";
      break;
    }
    if (c >= 0x20 && c < 0x7F) {
      out += char(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", unsigned(c));
      out += hex;
    }
  }
  return out + "'";
}

// Formats whose first bytes say what they are; none of them can begin an OBJ file.
std::string otherFormat(std::string_view bytes) {
  if (startsWith(bytes, "glTF"))
    return "this is a binary glTF file (magic 'glTF', .glb), not OBJ: " + std::string(kGlTFAdvice);
  if (startsWith(bytes, "\x89PNG\r\n\x1A\n")) return "this is a PNG image, not an OBJ mesh";
  if (startsWith(bytes, "\xFF\xD8\xFF")) return "this is a JPEG image, not an OBJ mesh";
  if (startsWith(bytes, std::string_view("PK\x03\x04", 4)))
    return "this is a ZIP archive (.zip, .usdz, .3mf, ...), not OBJ: unpack the .obj file from it";
  if (startsWith(bytes, "\x1F\x8B")) return "this file is gzip-compressed: decompress it (gunzip) first";
  if (startsWith(bytes, "Kaydara FBX Binary")) return "this is an FBX file, not OBJ: FBX is not supported";
  if (startsWith(bytes, "ply\n") || startsWith(bytes, "ply\r"))
    return "this is a PLY file, not OBJ: PLY is not supported";
  return "";
}

// What a text file that begins with `c` (its first non-blank character) is, if not OBJ.
std::string otherTextFormat(std::string_view text) {
  if (text.empty()) return "";
  if (text[0] == '{') {
    if (text.find("\"asset\"") != std::string_view::npos)
      return "this is a glTF file (JSON), not OBJ: " + std::string(kGlTFAdvice);
    return "this is a JSON file, not OBJ";
  }
  if (text[0] == '[') return "this is a JSON file, not OBJ";
  if (text[0] == '<') return "this is an XML or HTML file (a web page saved instead of the raw file?), not OBJ";
  if (startsWith(text, "solid ") || startsWith(text, "solid\n") || startsWith(text, "solid\r"))
    return "this is an ASCII STL file ('solid'), not OBJ: STL is not supported";
  return "";
}

// Control characters never occur in OBJ text (tabs, line breaks, \v and \f aside). A DOS
// end-of-file mark (^Z) is tolerated as the very last byte.
std::string binaryProblem(std::string_view bytes) {
  for (size_t k = 0; k < bytes.size(); ++k) {
    const unsigned char c = static_cast<unsigned char>(bytes[k]);
    const bool control = (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\v' && c != '\f') || c == 0x7F;
    if (!control || (c == 0x1A && k + 1 == bytes.size())) continue;
    char what[96];
    std::snprintf(what, sizeof what, "binary data (byte 0x%02X at offset %zu), not an OBJ text file", unsigned(c), k);
    return what;
  }
  return "";
}

// The largest vertex coordinate accepted. Positions are read in double and re-centred on the
// camera (where the loader bounds their distance further); beyond 1e30 no file describes a real
// scene, and the value is a broken or mis-scaled file.
constexpr double kMaxObjCoordinate = 1e30;

bool isBlank(char c) { return c == ' ' || c == '\t'; }

// The end of the line that starts at `pos`: its first '\r' or '\n', or the end of the text. (A
// plain loop: string_view::find_first_of calls memchr on the set for every character.)
size_t lineEnd(std::string_view text, size_t pos) {
  while (pos < text.size() && text[pos] != '\n' && text[pos] != '\r') ++pos;
  return pos;
}

// The whitespace-separated tokens of a statement (after its keyword), into `out`.
void tokens(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  size_t k = 0;
  while (k < s.size()) {
    while (k < s.size() && isBlank(s[k])) ++k;
    const size_t start = k;
    while (k < s.size() && !isBlank(s[k])) ++k;
    if (k > start) out.push_back(s.substr(start, k - start));
  }
}

bool parseInteger(std::string_view s, int64_t& value) {
  if (s.empty()) return false;
  if (s[0] == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && end == s.data() + s.size();
}

bool parseNumber(std::string_view s, double& value) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value, std::chars_format::general);
  return ec == std::errc() && end == s.data() + s.size() && std::isfinite(value);
}

enum class Statement { kUnknown, kVertex, kFace, kLineOrPoint, kFreeForm, kOther };

Statement classify(std::string_view keyword) {
  if (keyword == "v") return Statement::kVertex;
  if (keyword == "f" || keyword == "fo") return Statement::kFace;
  if (keyword == "l" || keyword == "p") return Statement::kLineOrPoint;
  static constexpr std::array<std::string_view, 18> kFreeForm = {"vp",    "cstype", "deg",  "bmat",  "step",  "curv",
                                                                 "curv2", "surf",   "parm", "trim",  "hole",  "scrv",
                                                                 "sp",    "end",    "con",  "ctech", "stech", "res"};
  for (std::string_view k : kFreeForm)
    if (keyword == k) return Statement::kFreeForm;
  // Texture coordinates, normals, grouping, display and rendering attributes (OBJ spec, B1).
  static constexpr std::array<std::string_view, 19> kOther = {
      "vt",     "vn",     "g",          "s",         "mg",     "o",      "bevel", "c_interp", "d_interp", "lod",
      "usemtl", "mtllib", "shadow_obj", "trace_obj", "maplib", "usemap", "call",  "csh",      "vw"};
  for (std::string_view k : kOther)
    if (keyword == k) return Statement::kOther;
  return Statement::kUnknown;
}

class Checker {
 public:
  explicit Checker(std::string_view bytes) : bytes_(bytes) {}
  // In place: the text is written over the bytes already read (it is never longer than they are,
  // but for a line break after a last line that has none, appended at the end).
  explicit Checker(std::string&& bytes) : owned_(std::move(bytes)), inPlace_(true) { bytes_ = owned_; }

  ObjCheck run() {
    ObjCheck result;
    result.problem = check();
    if (result.problem.empty() && inPlace_) {
      owned_.resize(written_);
      owned_.append(pendingLineBreak_ ? 1 : 0, '\n');
      result.text = std::move(owned_);
    } else if (result.problem.empty()) {
      result.text = std::move(text_);
    }
    result.vertices = vertices_;
    result.faces = faces_;
    return result;
  }

 private:
  std::string check() {
    if (bytes_.empty()) return "empty file (0 bytes)";
    if (std::string other = otherFormat(bytes_); !other.empty()) return other;
    std::string_view text = bytes_;
    if (startsWith(text, kBom)) text.remove_prefix(kBom.size());
    const size_t firstVisible = text.find_first_not_of(" \t\r\n\v\f");
    if (firstVisible == std::string_view::npos) return "empty file (only whitespace)";
    if (std::string other = otherTextFormat(text.substr(firstVisible)); !other.empty()) return other;
    if (std::string binary = binaryProblem(bytes_); !binary.empty()) return binary;

    if (!inPlace_) text_.reserve(text.size() + 1);
    size_t pos = 0, line = 0;
    while (pos < text.size()) {
      // One statement: a physical line, and the lines it continues onto with a final backslash.
      const size_t firstLine = line + 1;
      // The statement: the line itself, or (continued) the lines joined in `joined`.
      std::string_view statement;
      std::string joined;
      size_t physical = 0;
      for (;;) {
        const size_t end = lineEnd(text, pos);
        std::string_view part = text.substr(pos, end - pos);
        pos = end;
        if (pos < text.size()) pos += (text[pos] == '\r' && pos + 1 < text.size() && text[pos + 1] == '\n') ? 2 : 1;
        ++physical;
        ++line;
        while (!part.empty() && isBlank(part.back())) part.remove_suffix(1);
        const size_t lead = part.find_first_not_of(" \t");
        const bool comment = joined.empty() && lead != std::string_view::npos && part[lead] == '#';
        if (!comment && !part.empty() && part.back() == '\\' && pos < text.size()) {
          part.remove_suffix(1);
          joined.append(part);
          joined += ' ';
          continue;
        }
        if (!comment && !part.empty() && part.back() == '\\') part.remove_suffix(1);  // at the end of the file
        if (joined.empty()) {
          statement = part;
        } else {
          joined.append(part);
          statement = joined;
        }
        break;
      }
      if (std::string problem = checkStatement(statement, firstLine); !problem.empty()) return problem;
      putLineBreaks(physical);
    }
    if (faces_ == 0) {
      if (vertices_ == 0 && !sawStatement_) return "no faces: the file holds only comments";
      std::string what = "no faces: " + std::to_string(vertices_) + " vertices but no 'f' statement";
      if (sawLines_) what += " (lines and points have no area and are not rendered)";
      if (sawFreeForm_) what += " (free-form curves and surfaces are not supported, only polygons)";
      return what;
    }
    return "";
  }

  // Checks one statement and appends it (without its line break) to text_.
  std::string checkStatement(std::string_view s, size_t line) {
    const size_t lead = s.find_first_not_of(" \t");
    if (lead == std::string_view::npos || s[lead] == '#') return "";
    s.remove_prefix(lead);
    const size_t keywordEnd = std::min(s.find_first_of(" \t"), s.size());
    const std::string_view keyword = s.substr(0, keywordEnd);
    // (Messages are built only for a problem: never for the millions of good statements.)
    const auto at = [line] { return "line " + std::to_string(line) + ": "; };
    const Statement kind = classify(keyword);
    if (kind == Statement::kUnknown) return at() + quoted(keyword) + " is not an OBJ statement";
    sawStatement_ = true;
    tokens(s.substr(keywordEnd), args_);
    const std::vector<std::string_view>& args = args_;
    // Texture coordinates, normals and parameter-space vertices are not rendered, but a NaN or a
    // word among them is a broken file all the same (tinyobjloader would read it as 0).
    if (keyword == "vt" || keyword == "vn" || keyword == "vp") {
      const bool normal = keyword == "vn";
      const size_t least = normal ? 3 : 1, most = 3;
      if (args.size() < least || args.size() > most) {
        const std::string what = normal            ? "a normal is 'vn i j k'"
                                 : keyword == "vt" ? "a texture coordinate is 'vt u [v [w]]'"
                                                   : "a parameter vertex is 'vp u [v [w]]'";
        return at() + what + ", got " + std::to_string(args.size()) + " numbers";
      }
      for (std::string_view a : args) {
        double x;
        if (!parseNumber(a, x)) return at() + quoted(a) + " is not a finite number";
      }
    }
    switch (kind) {
      case Statement::kVertex: {
        if (args.size() < 3 || args.size() > 7)
          return at() + "a vertex is 'v x y z' (with an optional w or colour), got " + std::to_string(args.size()) +
                 " numbers";
        for (size_t k = 0; k < args.size(); ++k) {
          double x;
          if (!parseNumber(args[k], x)) return at() + quoted(args[k]) + " is not a finite number";
          if (k < 3 && std::abs(x) > kMaxObjCoordinate)
            return at() + "coordinate " + quoted(args[k]) + " is beyond 1e30 in magnitude, the largest accepted: " +
                   "no scene is that large (a broken or mis-scaled file)";
        }
        ++vertices_;
        break;
      }
      case Statement::kFace: {
        if (args.size() < 3) return at() + "a face needs at least 3 vertices, got " + std::to_string(args.size());
        for (std::string_view a : args)
          if (std::string problem = checkReference(a, true); !problem.empty()) return at() + problem;
        ++faces_;
        put("f");
        put(s.substr(keywordEnd));
        return "";
      }
      case Statement::kLineOrPoint: {
        for (std::string_view a : args)
          if (std::string problem = checkReference(a, false); !problem.empty()) return at() + problem;
        sawLines_ = true;
        break;
      }
      case Statement::kFreeForm: sawFreeForm_ = true; break;
      default: break;
    }
    put(s);
    return "";
  }

  // Appends to the text. In place, over bytes already read: a statement is written no longer than
  // it was read, and its line breaks with at most as many characters as it had (1 or 2 each); so
  // only the break of a last line that has none can find no room, and run() appends it.
  void put(std::string_view s) {
    if (!inPlace_) {
      text_.append(s);
      return;
    }
    std::memmove(owned_.data() + written_, s.data(), s.size());
    written_ += s.size();
  }
  void putLineBreaks(size_t count) {
    if (!inPlace_) {
      text_.append(count, '\n');
      return;
    }
    const size_t room = std::min(count, owned_.size() - written_);
    std::memset(owned_.data() + written_, '\n', room);
    written_ += room;
    pendingLineBreak_ = room < count;
  }

  // One vertex of a face (v, v/vt, v//vn or v/vt/vn) or of a line or point element.
  std::string checkReference(std::string_view ref, bool face) {
    std::array<std::string_view, 3> parts;
    size_t count = 0, start = 0;
    for (size_t k = 0; k <= ref.size(); ++k) {
      if (k < ref.size() && ref[k] != '/') continue;
      if (count == 3) return quoted(ref) + " is not a vertex reference (v, v/vt, v//vn or v/vt/vn)";
      parts[count++] = ref.substr(start, k - start);
      start = k + 1;
    }
    for (size_t k = 0; k < count; ++k) {
      if (k > 0 && parts[k].empty()) continue;  // v//vn, or a trailing slash
      int64_t index;
      if (!parseInteger(parts[k], index) || index == 0)
        return quoted(ref) + " is not a vertex reference (indices are non-zero integers, counted from 1)";
      if (k == 0 && face) {
        const int64_t defined = int64_t(vertices_);
        if (index > defined || -index > defined)
          return "face refers to vertex " + std::to_string(index) + ", but " +
                 (defined == 0 ? std::string("no vertex is") : "only " + std::to_string(defined) + " vertices are") +
                 " defined before it";
      }
    }
    return "";
  }

  std::string_view bytes_;
  std::string text_;
  std::string owned_;  // in place: the bytes, then the text over them
  bool inPlace_ = false, pendingLineBreak_ = false;
  size_t written_ = 0;                  // in place: the text's length so far
  std::vector<std::string_view> args_;  // the current statement's tokens (reused: no allocation per line)
  size_t vertices_ = 0, faces_ = 0;
  bool sawStatement_ = false, sawLines_ = false, sawFreeForm_ = false;
};

}  // namespace

ObjCheck checkObjText(std::string_view bytes) { return Checker(bytes).run(); }

ObjCheck checkObjTextInPlace(std::string bytes) { return Checker(std::move(bytes)).run(); }

}  // namespace lensfarm
