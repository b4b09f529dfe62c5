#include "common/util/secret.h"
#include "common/util/file_contents.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm {

namespace {
std::string trimmed(std::string s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}
}  // namespace

std::optional<std::string> readToken(const std::string& file, const char* env) {
  if (!file.empty()) {
    const std::string token = trimmed(readWholeFileOrThrow(file, file));
    if (token.empty()) throw InputError(file, "the token file is empty");
    return token;
  }
  if (env) {
    if (const char* value = std::getenv(env); value && *value) return trimmed(value);
  }
  return std::nullopt;
}

void checkTokenStrength(const std::string& token, const std::string& source) {
  static constexpr const char* kHowTo = "; make one with: head -c 32 /dev/urandom | base64";
  std::string lower = token;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::erase_if(lower, [](char c) { return c == '-' || c == '_' || c == ' ' || c == '.'; });
  for (const char* placeholder : {"replaceme", "changeme", "placeholder", "example", "yourtoken", "yoursecret",
                                  "insert", "fixme", "xxxxxx", "secrettoken", "password"})
    if (lower.find(placeholder) != std::string::npos)
      throw InputError(source, std::string("the token is a placeholder (it contains \"") + placeholder +
                                   "\"), not a secret: replace it" + kHowTo);
  if (token.size() < kMinTokenLength)
    throw InputError(source, "the token has " + std::to_string(token.size()) + " characters; at least " +
                                 std::to_string(kMinTokenLength) + " are needed" + kHowTo);
  const std::string distinct = [&] {
    std::string s = token;
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    return s;
  }();
  if (distinct.size() < 6)
    throw InputError(source, "the token has only " + std::to_string(distinct.size()) +
                                 " distinct characters: it is guessable" + kHowTo);
}

bool equalSecrets(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const size_t n = std::max(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

}  // namespace lensfarm
