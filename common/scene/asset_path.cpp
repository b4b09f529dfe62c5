#include "common/scene/asset_path.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <system_error>

namespace lensfarm {

namespace fs = std::filesystem;

namespace {

// A URI scheme (RFC 3986, 3.1): a letter, then letters, digits, '+', '-', '.', then ':'. One
// letter before the colon is a Windows drive ("C:"), which is an absolute path instead.
std::optional<std::string> schemeOf(const std::string& path) {
  const size_t colon = path.find(':');
  if (colon == std::string::npos || colon < 2 || !std::isalpha(static_cast<unsigned char>(path[0])))
    return std::nullopt;
  for (size_t k = 1; k < colon; ++k) {
    const unsigned char c = static_cast<unsigned char>(path[k]);
    if (!std::isalnum(c) && c != '+' && c != '-' && c != '.') return std::nullopt;
  }
  return path.substr(0, colon);
}

// Whether `path` (absolute, normal form) is `dir` or lies below it, component by component.
bool isInside(const fs::path& path, const fs::path& dir) {
  auto p = path.begin();
  for (auto d = dir.begin(); d != dir.end(); ++d, ++p) {
    if (d->empty()) continue;  // the trailing "" of "dir/"
    if (p == path.end() || *p != *d) return false;
  }
  return true;
}

fs::path absoluteNormal(const fs::path& p) {
  std::error_code ec;
  const fs::path a = fs::absolute(p, ec);
  return (ec ? p : a).lexically_normal();
}

// The path with every symlink resolved, as far as it exists (the rest as written).
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  const fs::path r = fs::weakly_canonical(p, ec);
  return ec ? absoluteNormal(p) : r;
}

}  // namespace

std::optional<std::string> unreadablePathProblem(const std::string& path) {
  if (path.empty()) return "is empty: name a file";
  if (path.find('\0') != std::string::npos) return "holds a NUL byte: not a file name";
  if (const std::optional<std::string> scheme = schemeOf(path)) {
    std::string lower = *scheme;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return "is a URL (" + lower +
           ":): lensfarm reads only files beside the scene and downloads nothing; download it and "
           "name the file by a relative path";
  }
  return std::nullopt;
}

fs::path confinedFile(const fs::path& root, const std::string& path, const std::vector<fs::path>& allowed) {
  if (const std::optional<std::string> problem = unreadablePathProblem(path)) throw AssetRefused(*problem);
  const fs::path rootAbs = absoluteNormal(root);
  const bool windowsDrive = path.size() >= 2 && std::isalpha(static_cast<unsigned char>(path[0])) && path[1] == ':';
  const bool absolute = path[0] == '/' || path[0] == '\\' || windowsDrive;
  const fs::path file = (rootAbs / path).lexically_normal();
  std::vector<fs::path> roots{rootAbs};
  for (const fs::path& a : allowed) roots.push_back(absoluteNormal(a));
  for (const fs::path& a : allowedFoldersFromEnvironment()) roots.push_back(absoluteNormal(a));
  const auto insideAny = [&](const fs::path& p, bool resolveRoots) {
    return std::any_of(roots.begin(), roots.end(),
                       [&](const fs::path& r) { return isInside(p, resolveRoots ? resolved(r) : r); });
  };
  if ((absolute && windowsDrive) || !insideAny(file, false))
    throw AssetRefused(
        std::string(absolute ? "is an absolute path outside " : "lies outside ") + rootAbs.string() +
        ", the folder of the scene: a scene's files are named relative to it and lie inside it (to allow "
        "another folder, give --allow-path FOLDER or set LENSFARM_ALLOW_PATH)");
  if (!insideAny(resolved(file), true))
    throw AssetRefused("is a symlink to " + resolved(file).string() + ", outside " + rootAbs.string() +
                       ", the folder of the scene (to allow that folder, give --allow-path FOLDER)");
  return file;
}

std::vector<fs::path> allowedFoldersFromEnvironment() {
  std::vector<fs::path> folders;
  const char* value = std::getenv("LENSFARM_ALLOW_PATH");
  if (!value) return folders;
  const std::string text = value;
  for (size_t start = 0; start <= text.size();) {
    const size_t end = std::min(text.find(':', start), text.size());
    if (end > start) folders.emplace_back(text.substr(start, end - start));
    start = end + 1;
  }
  return folders;
}

}  // namespace lensfarm
