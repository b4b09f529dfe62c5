#include "util/file_contents.h"

#include <fstream>
#include <sstream>

#include "util/error.h"

namespace lensfarm {

std::optional<std::string> readWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return std::move(bytes).str();
}

std::string readWholeFileOrThrow(const std::filesystem::path& path, const std::string& where) {
  auto bytes = readWholeFile(path);
  if (!bytes) throw InputError(where, "cannot read \"" + path.string() + "\"");
  return std::move(*bytes);
}

}  // namespace lensfarm
