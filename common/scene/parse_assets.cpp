// SceneParser, assets: a file the scene names, read through the asset reader, added to the
// scene's hash and recorded in its assets (so the farm ships it to workers).
#include <tbb/parallel_invoke.h>

#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

#include "common/scene/asset_path.h"
#include "common/scene/scene_parser.h"
#include "common/util/field_reader.h"
#include "common/util/hash.h"

namespace lensfarm {

namespace fs = std::filesystem;

LoadedAsset SceneParser::readAssetFile(FieldReader& r, const std::string& key, const std::string& kind) {
  const std::string rel = r.string(key);
  if (const std::optional<std::string> problem = unreadablePathProblem(rel))
    r.fail(r.field(key), "\"" + rel + "\" " + *problem);
  const fs::path path = file_.parent_path() / rel;
  std::optional<std::string> content;
  try {
    content = readAsset_(rel);
  } catch (const AssetRefused& e) {
    r.fail(r.field(key), "\"" + rel + "\" " + e.what());
  }
  if (!content) r.fail(r.field(key), "cannot read " + kind + " \"" + path.string() + "\": " + missingFile(path));
  addAssetHash(rel, *content);
  return LoadedAsset{path.string(), std::move(*content)};
}

std::string SceneParser::missingFile(const fs::path& path) {
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec).lexically_normal();
  const std::string shown = ec ? path.string() : absolute.string();
  if (fs::is_directory(path, ec)) return "is a folder, not a file (" + shown + ")";
  if (fs::exists(path, ec)) return "cannot be opened (" + shown + "; check its permissions)";
  return "no such file (looked for " + shown + ")";
}

void SceneParser::addAssetHash(const std::string& rel, const std::string& content) {
  std::string own;
  tbb::parallel_invoke([&] { hash_.update(rel), hash_.update(content); }, [&] { own = sha256Hex(content); });
  scene_.assets[rel] = std::move(own);
}

}  // namespace lensfarm
