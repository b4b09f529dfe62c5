#pragma once
// Where the files a scene names may come from.
//
// A scene, an OBJ, an MTL library and a glTF model name other files by paths relative to
// themselves. Every such path must lead to a file inside the asset root, the folder of the file
// the user gave (the scene file, or the model file rendered as it is), or inside a folder the user
// allowed explicitly (`--allow-path`, or LENSFARM_ALLOW_PATH for every scene): no `..` that climbs
// out of it, no absolute path, no symlink whose target lies outside, and no URL (nothing is
// downloaded). So rendering or submitting a
// downloaded model reads nothing but the model's own files, and `lensfarm submit` never uploads a
// file the user did not mean to share. On a coordinator or worker, assets come from the job's
// uploaded files by name, never from the machine's file system.
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace lensfarm {

// A path the rules above refuse; what() says why, in words that follow the path in a message
// ("\"../x.bin\" " + what()).
class AssetRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Why a path as a file writes it can name no file to read: a URL ("http://...", "file:..."), an
// empty one or one with a NUL byte; nothing for a path. Whether it leads out of its folder (a
// `..`, an absolute path, a symlink) is the file reader's question (confinedFile), because an
// allowed folder may hold it.
std::optional<std::string> unreadablePathProblem(const std::string& path);

// The file at `path` (relative to `root`, or absolute), if it lies inside `root` or one of
// `allowed` both as written and with every symlink resolved; throws AssetRefused otherwise. The
// path returned is the one to open.
std::filesystem::path confinedFile(const std::filesystem::path& root, const std::string& path,
                                   const std::vector<std::filesystem::path>& allowed);

// The folders of LENSFARM_ALLOW_PATH (colon-separated; empty entries skipped): allowed for every
// scene read on this machine, beside those given with --allow-path.
std::vector<std::filesystem::path> allowedFoldersFromEnvironment();

}  // namespace lensfarm
