#include "client/output_paths.h"

#include "common/util/error.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

fs::path checkedOutput(const std::string& o, const std::vector<std::string>& extensions) {
  const fs::path path(o);
  const std::string ext = path.extension().string();
  bool known = false;
  std::string expected;
  for (const auto& e : extensions) {
    known |= ext == e;
    expected += (expected.empty() ? "" : " or ") + e;
  }
  if (!known) throw InputError("-o " + o, "unknown image format \"" + ext + "\" (expected " + expected + ")");
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(dir)) throw InputError("-o " + o, "directory \"" + dir.string() + "\" does not exist");
  return path;
}

std::vector<std::string> defaultOutputs(const std::string& scene) {
  const std::string stem = fs::path(scene).stem().string();
  return {stem + ".exr", stem + ".png"};
}

}  // namespace lensfarm::cli
