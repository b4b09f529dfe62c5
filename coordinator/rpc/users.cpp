#include "coordinator/rpc/users.h"

#include <cctype>
#include <cstring>
#include <ctime>
#include <iomanip>
#include <set>
#include <sstream>

#include "common/farm/farm_types.h"
#include "common/util/error.h"
#include "common/util/file_contents.h"
#include "common/util/hash.h"
#include "common/util/secret.h"
#include "coordinator/rpc/worker_credentials.h"

namespace lensfarm {

const char* roleName(User::Role role) {
  switch (role) {
    case User::Role::kAdmin: return "admin";
    case User::Role::kSubmitter: return "submitter";
    case User::Role::kViewer: return "viewer";
  }
  return "viewer";
}

namespace {

// "expires=YYYY-MM-DD" or "expires=YYYY-MM-DDTHH:MM:SSZ" as Unix seconds (UTC); nullopt if malformed.
std::optional<int64_t> parseExpiry(const std::string& field) {
  const std::string prefix = "expires=";
  if (field.rfind(prefix, 0) != 0) return std::nullopt;
  const std::string when = field.substr(prefix.size());
  std::tm tm{};
  std::istringstream in(when);
  if (when.size() == 10)
    in >> std::get_time(&tm, "%Y-%m-%d");
  else if (when.size() == 20 && when.back() == 'Z')
    in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%S");
  else
    return std::nullopt;
  if (in.fail() || tm.tm_year < 70 || tm.tm_year > 1100) return std::nullopt;
  std::tm check = tm;
  const time_t seconds = timegm(&check);
  // timegm normalises 2027-02-30 to March: such a date was not a date.
  if (check.tm_mday != tm.tm_mday || check.tm_mon != tm.tm_mon) return std::nullopt;
  return int64_t(seconds);
}

}  // namespace

std::string User::expiryText() const {
  if (!expiresUnixSeconds) return "";
  const time_t t = time_t(*expiresUnixSeconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::vector<User> parseUsers(const std::string& text, const std::string& source) {
  std::vector<User> out;
  std::set<std::string> names, hashes;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const std::string where = source + ":" + std::to_string(number);
    std::istringstream fields(line);
    User u;
    std::string role, expiry, extra;
    if (!(fields >> u.name) || u.name[0] == '#') continue;
    if (!(fields >> role >> u.tokenSha256) || ((fields >> expiry) && (fields >> extra)))
      throw InputError(where,
                       "expected a name, a role and the SHA-256 of the user's token (and an expiry), separated by "
                       "white space");
    if (!expiry.empty() && !(u.expiresUnixSeconds = parseExpiry(expiry)))
      throw InputError(
          where, "\"" + expiry.substr(0, 40) + "\": expected expires=YYYY-MM-DD or expires=YYYY-MM-DDTHH:MM:SSZ (UTC)");
    if (!isCredentialName(u.name))
      throw InputError(where, "a user name is 1-64 characters of letters, digits, '.', '_' and '-'");
    if (role == "admin")
      u.role = User::Role::kAdmin;
    else if (role == "submitter")
      u.role = User::Role::kSubmitter;
    else if (role == "viewer")
      u.role = User::Role::kViewer;
    else
      throw InputError(where, "unknown role \"" + role.substr(0, 32) + "\" (admin, submitter, viewer)");
    if (!names.insert(u.name).second) throw InputError(where, "user " + u.name + " is given twice");
    if (u.tokenSha256.rfind("cert=", 0) == 0) {  // a client certificate's name instead of a token
      u.certificateName = u.tokenSha256.substr(5);
      u.tokenSha256.clear();
      bool name = !u.certificateName.empty() && u.certificateName.size() <= 64;
      for (char c : u.certificateName) name = name && (std::isalnum((unsigned char)c) || std::strchr("._@-", c));
      if (!name)
        throw InputError(where,
                         "cert=NAME: a certificate name is 1-64 characters of letters, digits, '.', '_', '@' "
                         "and '-'");
      if (!hashes.insert("cert=" + u.certificateName).second)
        throw InputError(where, "the certificate " + u.certificateName + " is another user's too");
      out.push_back(std::move(u));
      continue;
    }
    bool hex = u.tokenSha256.size() == 64;
    for (char c : u.tokenSha256) hex = hex && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    if (!hex)
      throw InputError(where,
                       "the third field is the SHA-256 of the token, 64 lowercase hex digits (printf %s \"$TOKEN\" "
                       "| sha256sum), never the token itself");
    if (!hashes.insert(u.tokenSha256).second)
      throw InputError(where, "the token of " + u.name + " is another user's too: each person needs their own");
    out.push_back(std::move(u));
  }
  if (out.empty()) throw InputError(source, "holds no user (lines of: NAME ROLE SHA256)");
  return out;
}

std::vector<User> readUsers(const std::string& file) {
  checkTokenFileMode(file);
  return parseUsers(readWholeFileOrThrow(file, file), file);
}

std::optional<User> userOfToken(const std::vector<User>& users, const std::string& token) {
  const std::string hash = sha256Hex(token);
  std::optional<User> found;
  for (const User& u : users)  // every hash compared: the time says nothing of which matched
    if (!u.tokenSha256.empty() && equalSecrets(hash, u.tokenSha256)) found = u;
  return found;
}

std::optional<User> userOfCertificate(const std::vector<User>& users, const std::string& commonName) {
  for (const User& u : users)
    if (!u.certificateName.empty() && u.certificateName == commonName) return u;
  return std::nullopt;
}

void checkMayAct(const User& user, const std::string& action, const std::string& jobId, const std::string& owner) {
  if (user.role == User::Role::kAdmin) return;
  if (user.role == User::Role::kSubmitter && owner == user.name) return;
  if (user.role == User::Role::kViewer)
    throw FarmError(
        FarmError::Kind::kPermissionDenied,
        action + " " + jobId + ": " + user.name + " is a viewer: reading only (an admin or the job's owner may)");
  throw FarmError(FarmError::Kind::kPermissionDenied,
                  action + " " + jobId + ": " + user.name + " (submitter) may act on their own jobs only; " + jobId +
                      " is " + (owner.empty() ? std::string("nobody's") : owner + "'s") + " (an admin may)");
}

}  // namespace lensfarm
