#include "coordinator/rpc/users.h"

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

std::vector<User> parseUsers(const std::string& text, const std::string& source) {
  std::vector<User> out;
  std::set<std::string> names, hashes;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const std::string where = source + ":" + std::to_string(number);
    std::istringstream fields(line);
    User u;
    std::string role, extra;
    if (!(fields >> u.name) || u.name[0] == '#') continue;
    if (!(fields >> role >> u.tokenSha256) || (fields >> extra))
      throw InputError(where, "expected a name, a role and the SHA-256 of the user's token, separated by white space");
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
    bool hex = u.tokenSha256.size() == 64;
    for (char c : u.tokenSha256) hex = hex && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    if (!hex)
      throw InputError(where,
                       "the third field is the SHA-256 of the token, 64 lowercase hex digits (printf %s \"$TOKEN\" "
                       "| sha256sum), never the token itself");
    if (!names.insert(u.name).second) throw InputError(where, "user " + u.name + " is given twice");
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
    if (equalSecrets(hash, u.tokenSha256)) found = u;
  return found;
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
