#pragma once
// Per-machine worker credentials (docs/farm.md "Worker identity"). The shared worker token makes a
// pool: every holder is trusted, and one holder may register any number of workers. A credential
// is one machine: its token registers one worker at a time (a new registration supersedes the
// last, WorkerRegistry::add), and everything the farm counts per worker — failures of a unit,
// the blocklist, the audit's votes, quarantine — counts the credential once, however often it
// registers.
//
// The file (--worker-credentials), one credential a line, `#` comments and blank lines ignored:
//
//   # name     token
//   render-01  4mS2...Qe0=
//   render-02  b9Xt...1kw=
//
// A name is 1-64 characters of [A-Za-z0-9._-]; a token passes checkTokenStrength and is unique
// in the file. Like a token file, the file must not be readable by others (checkTokenFileMode).
#include <string>
#include <vector>

namespace lensfarm {

struct WorkerCredential {
  std::string name;
  std::string token;
};

// Whether `name` is a credential's (or a user's, users.h) name: 1-64 characters of [A-Za-z0-9._-].
bool isCredentialName(const std::string& name);

// The credentials in `file`; InputError naming "FILE:LINE" and what is wrong (a malformed line, a
// bad name, a weak or repeated token, a name given twice), or the file when it holds none.
std::vector<WorkerCredential> readWorkerCredentials(const std::string& file);

// The same, from text (the file's contents; `source` names it in errors).
std::vector<WorkerCredential> parseWorkerCredentials(const std::string& text, const std::string& source);

}  // namespace lensfarm
