#include "common/util/secret.h"
#include "common/util/file_contents.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
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
// The shortest period p <= n/2 with token[i] == token[i - p] for every i >= p, or 0.
size_t repeatPeriod(const std::string& token) {
  for (size_t p = 1; 2 * p <= token.size(); ++p) {
    size_t i = p;
    while (i < token.size() && token[i] == token[i - p]) ++i;
    if (i == token.size()) return p;
  }
  return 0;
}

// How many characters follow from the one before as a person types a run: the same again, or the
// next or previous in the alphabet "0-9a-z" (case ignored), counting 9 -> a and z -> 0 as steps.
// A random base64 token of 44 characters has about 3; "0123456789abcdef" has 15 of 15.
size_t predictableSteps(const std::string& token) {
  const auto rank = [](char c) -> int {
    const char lower = char(std::tolower(static_cast<unsigned char>(c)));
    if (lower >= '0' && lower <= '9') return lower - '0';
    if (lower >= 'a' && lower <= 'z') return 10 + lower - 'a';
    return -100 - static_cast<unsigned char>(c);  // other characters: only a repeat is a step
  };
  size_t steps = 0;
  for (size_t i = 1; i < token.size(); ++i) {
    const int a = rank(token[i - 1]), b = rank(token[i]);
    const int d = a >= 0 && b >= 0 ? (b - a + 36) % 36 : (a == b ? 0 : 2);
    steps += d == 0 || d == 1 || d == 35;
  }
  return steps;
}
}  // namespace

void checkTokenFileMode(const std::string& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) return;  // reading it says why
  const bool others = st.st_mode & (S_IROTH | S_IWOTH);
  const bool group = st.st_mode & (S_IRGRP | S_IWGRP);
  if (!others && !(group && st.st_uid != 0)) return;
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", unsigned(st.st_mode & 07777));
  throw InputError(file, std::string("the token file is ") + (others ? "readable by anyone" : "readable by its group") +
                             " (mode " + mode + "); make it its owner's alone: chmod 600 " + file);
}

std::optional<std::string> readToken(const std::string& file, const char* env) {
  if (!file.empty()) {
    checkTokenFileMode(file);
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
  if (const size_t period = repeatPeriod(token))
    throw InputError(
        source, "the token repeats a pattern of " + std::to_string(period) + " characters: it is guessable" + kHowTo);
  if (2 * predictableSteps(token) > token.size() - 1)
    throw InputError(source,
                     std::string("the token is mostly a run (like 0123... or abcd...): it is guessable") + kHowTo);
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
