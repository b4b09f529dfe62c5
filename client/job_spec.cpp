#include "job_spec.h"

#include "scene/scene_loader.h"
#include "util/error.h"
#include "util/file_contents.h"

namespace lensfarm::cli {

LocalJob makeLocalJob(const std::filesystem::path& sceneFile, const RenderOverrides& overrides,
                      const std::optional<std::string>& camera, const std::optional<FrameRange>& frames,
                      const std::vector<std::filesystem::path>& allowedFolders) {
  LocalJob job;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(sceneFile, ec)) throw InputError(sceneFile.string(), "no such scene file");
  // Keep what the loader reads, so assets are read once and uploaded exactly as loaded.
  std::map<std::string, std::string> read;
  const AssetReader fromDisk = fileAssetReader(sceneFile, allowedFolders);
  const AssetReader keep = [&](const std::string& path) {
    auto bytes = fromDisk(path);
    if (bytes) read[path] = *bytes;
    return bytes;
  };
  if (isModelFile(sceneFile)) {
    // A model rendered as it is: the farm gets the scene written for it (scene/scene_loader.h).
    job.scene = modelScene(sceneFile, job.spec.sceneJson, keep, camera);
  } else {
    job.spec.sceneJson = readWholeFileOrThrow(sceneFile, sceneFile.string());
    if (camera) job.spec.sceneJson = withModelCamera(job.spec.sceneJson, sceneFile, *camera);
    job.scene = parseScene(job.spec.sceneJson, sceneFile, keep);
  }
  applyOverrides(overrides, job.scene.render, "command line");
  try {
    (void)job.scene.camera();
  } catch (const InputError& e) {
    throw InputError(sceneFile.string(), std::string("camera.") + e.what());
  }
  job.spec.sceneName = sceneFile.filename().string();
  job.spec.assets = job.scene.assets;
  job.spec.overrides = overrides;
  job.spec.frames = frames;
  if (frames && job.scene.render.convergenceDriven())
    throw InputError("--frames", "an animation renders every frame to its samples; --target-error and --deadline "
                                 "are for a still");
  for (const auto& [path, sha] : job.scene.assets) job.assetBytes[sha] = std::move(read.at(path));
  return job;
}

}  // namespace lensfarm::cli
