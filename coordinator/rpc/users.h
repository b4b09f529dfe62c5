#pragma once
// People on the client service (docs/farm.md "People and permissions"): one identity per user,
// each with a role and a token of their own, of which the coordinator keeps only the SHA-256.
//
// The file (--users), one user a line, `#` comments and blank lines ignored:
//
//   # name   role       sha256 of the token (printf %s "$TOKEN" | sha256sum)
//   ann      submitter  0a4f...e3
//   bob      viewer     77c1...90
//
// Roles: `admin` (everything, on every job, as the client token), `submitter` (submits; reads
// every job; acts — cancel, delete, archive, pause, resume, approve — on their own jobs only) and
// `viewer` (reads only). A name is 1-64 characters of [A-Za-z0-9._-]; the owner of a job a user
// submits is their name, whatever the request says.
#include <optional>
#include <string>
#include <vector>

namespace lensfarm {

struct User {
  enum class Role { kAdmin, kSubmitter, kViewer };
  std::string name;
  Role role = Role::kViewer;
  std::string tokenSha256;  // 64 lowercase hex digits
};
const char* roleName(User::Role role);

// The users in `text` (a file's contents; `source` names it in errors): InputError naming
// "FILE:LINE" for a malformed line, a bad name, an unknown role, a hash that is not 64 hex digits,
// a name or hash given twice; or the file when it holds no user.
std::vector<User> parseUsers(const std::string& text, const std::string& source);
// The same from `file`, which must not be readable by others (checkTokenFileMode).
std::vector<User> readUsers(const std::string& file);

// The user whose token is `token` (compared by its SHA-256, every user's hash in constant time),
// or nullopt.
std::optional<User> userOfToken(const std::vector<User>& users, const std::string& token);

// Whether `user` may act on a job owned by `owner` (cancel, delete, archive, pause, resume,
// approve): FarmError kPermissionDenied naming the user, their role, the action and the job's
// owner otherwise.
void checkMayAct(const User& user, const std::string& action, const std::string& jobId, const std::string& owner);

}  // namespace lensfarm
