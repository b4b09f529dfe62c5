#include "common/util/file_contents.h"

#include <fstream>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm {

std::optional<std::string> readWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  // A regular file is read in one go into a string of its size (a growing string stream would
  // copy it as it doubles, holding up to twice the file at its peak); then whatever the stream
  // still has (a file that grew meanwhile, or all of what is not a regular file).
  std::string bytes;
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) {
    const uintmax_t size = std::filesystem::file_size(path, ec);
    if (!ec && size > 0) {
      bytes.resize(size_t(size));
      in.read(bytes.data(), std::streamsize(size));
      bytes.resize(size_t(in.gcount()));
      in.clear();
    }
  }
  std::ostringstream rest;
  rest << in.rdbuf();
  if (bytes.empty()) return std::move(rest).str();
  bytes += std::move(rest).str();
  return bytes;
}

std::string readWholeFileOrThrow(const std::filesystem::path& path, const std::string& where) {
  auto bytes = readWholeFile(path);
  if (!bytes) throw InputError(where, "cannot read \"" + path.string() + "\"");
  return std::move(*bytes);
}

}  // namespace lensfarm
