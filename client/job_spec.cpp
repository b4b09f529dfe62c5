#include "job_spec.h"

#include <fstream>
#include <sstream>

#include "scene/scene_loader.h"
#include "util/error.h"

namespace lensfarm::cli {

LocalJob makeLocalJob(const std::filesystem::path& sceneFile, const RenderOverrides& overrides) {
  Scene scene = loadScene(sceneFile);
  applyOverrides(overrides, scene.render, sceneFile.string());
  try {
    (void)scene.camera();
  } catch (const InputError& e) {
    throw InputError(sceneFile.string(), std::string("camera.") + e.what());
  }
  LocalJob job;
  std::ifstream in(sceneFile, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  job.spec.sceneName = sceneFile.filename().string();
  job.spec.sceneJson = text.str();
  job.spec.assets = scene.assets;
  job.spec.overrides = overrides;
  const AssetReader read = fileAssetReader(sceneFile);
  for (const auto& [path, sha] : scene.assets) {
    auto bytes = read(path);
    if (!bytes) throw InputError(sceneFile.string(), "cannot read asset " + path);
    job.assetBytes[sha] = std::move(*bytes);
  }
  return job;
}

}  // namespace lensfarm::cli
