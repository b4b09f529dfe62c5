#pragma once
// Secrets (authentication tokens) come from files or environment variables, never from a
// command-line argument that `ps` would show, and are never logged.
#include <optional>
#include <string>

namespace lensfarm {

// The token in `file` (surrounding whitespace trimmed), or else in environment variable `env`;
// nothing if neither is set. Throws InputError naming the file if it cannot be read or is empty,
// or if others can read it (checkTokenFileMode).
std::optional<std::string> readToken(const std::string& file, const char* env);

// Refuses (InputError naming the file, with the chmod to run) a token file that anyone but its
// owner may read or write: any "other" permission, or a group permission unless root owns the
// file (a secret mounted by Kubernetes or systemd: root-owned, readable by the service's group;
// PostgreSQL allows its key files on the same terms).
void checkTokenFileMode(const std::string& file);

// Refuses (InputError naming `source`) a token that a stranger could guess: shorter than
// kMinTokenLength characters, fewer than 6 distinct characters, a pattern repeated
// ("abcdef123456abcdef123456"), mostly a run ("0123456789abcdef"), or a known placeholder (a token
// containing "replace-me", "changeme", "placeholder", "example", ... as deploy files and tutorials
// ship them). `head -c 32 /dev/urandom | base64` makes a good one (44 characters).
inline constexpr size_t kMinTokenLength = 16;
void checkTokenStrength(const std::string& token, const std::string& source);

// Compares without leaking where the first difference is through timing.
bool equalSecrets(const std::string& a, const std::string& b);

}  // namespace lensfarm
