#include "coordinator/rpc/worker_credentials.h"

#include <cctype>
#include <set>
#include <sstream>

#include "common/util/error.h"
#include "common/util/file_contents.h"
#include "common/util/secret.h"

namespace lensfarm {

bool isCredentialName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (const unsigned char c : name)
    if (!std::isalnum(c) && c != '.' && c != '_' && c != '-') return false;
  return true;
}

std::vector<WorkerCredential> parseWorkerCredentials(const std::string& text, const std::string& source) {
  std::vector<WorkerCredential> out;
  std::set<std::string> names;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const std::string where = source + ":" + std::to_string(number);
    std::istringstream fields(line);
    WorkerCredential c;
    if (!(fields >> c.name) || c.name[0] == '#') continue;
    std::string extra;
    if (!(fields >> c.token) || (fields >> extra))
      throw InputError(where, "expected a name and a token separated by white space");
    if (!isCredentialName(c.name))
      throw InputError(where, "a credential name is 1-64 characters of letters, digits, '.', '_' and '-'");
    checkTokenStrength(c.token, where);
    if (!names.insert(c.name).second) throw InputError(where, "credential " + c.name + " is given twice");
    for (const WorkerCredential& earlier : out)
      if (equalSecrets(earlier.token, c.token))
        throw InputError(where,
                         "the token of " + c.name + " is also " + earlier.name + "'s: each machine needs its own");
    out.push_back(std::move(c));
  }
  if (out.empty()) throw InputError(source, "holds no credential (lines of: NAME TOKEN)");
  return out;
}

std::vector<WorkerCredential> readWorkerCredentials(const std::string& file) {
  checkTokenFileMode(file);
  return parseWorkerCredentials(readWholeFileOrThrow(file, file), file);
}

}  // namespace lensfarm
