#pragma once
// People on the client service (docs/farm.md "People and permissions"): one identity per user,
// each with a role and a token of their own, of which the coordinator keeps only the SHA-256.
//
// The file (--users), one user a line, `#` comments and blank lines ignored:
//
//   # name   role       sha256 of the token (printf %s "$TOKEN" | sha256sum)   [expiry]
//   ann      submitter  0a4f...e3
//   bob      viewer     77c1...90  expires=2027-03-31
//
// With mutual TLS (--tls-client-ca) a person may be known by their client certificate instead of
// a token: the third field `cert=COMMON-NAME` (the certificate's subject CN, as the CA signed it;
// 1-64 characters of letters, digits, '.', '_', '@' and '-'). A gRPC call that carries no token is
// then that person's when its verified certificate has that name; a call with a token is the
// token's. (The HTTP API and the dashboard take people's tokens only.)
//
// A token may expire: `expires=YYYY-MM-DD` (at 00:00 UTC that day) or
// `expires=YYYY-MM-DDTHH:MM:SSZ`; from then on it is refused as UNAUTHENTICATED naming when it
// expired, everywhere (gRPC, the HTTP API, the dashboard), until the file gives it a new date and
// the coordinator restarts.
//
// Roles: `admin` (everything, on every job, as the client token), `submitter` (submits; reads
// every job; acts — cancel, delete, archive, pause, resume, approve — on their own jobs only) and
// `viewer` (reads only). A name is 1-64 characters of [A-Za-z0-9._-]; the owner of a job a user
// submits is their name, whatever the request says.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace lensfarm {

struct User {
  enum class Role { kAdmin, kSubmitter, kViewer };
  std::string name;
  Role role = Role::kViewer;
  std::string tokenSha256;                      // 64 lowercase hex digits; empty for a certificate identity
  std::string certificateName{};                // the client certificate's CN (cert=NAME); empty for a token
  std::optional<int64_t> expiresUnixSeconds{};  // unset: never
  bool expired(int64_t nowUnixSeconds) const { return expiresUnixSeconds && nowUnixSeconds >= *expiresUnixSeconds; }
  std::string expiryText() const;  // "2027-03-31T00:00:00Z"; "" if it never expires
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
// The user known by the client certificate named `commonName`, or nullopt.
std::optional<User> userOfCertificate(const std::vector<User>& users, const std::string& commonName);

// Whether `user` may act on a job owned by `owner` (cancel, delete, archive, pause, resume,
// approve): FarmError kPermissionDenied naming the user, their role, the action and the job's
// owner otherwise.
void checkMayAct(const User& user, const std::string& action, const std::string& jobId, const std::string& owner);

}  // namespace lensfarm
