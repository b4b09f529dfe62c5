#include "client/job_spec.h"

#include "common/farm/job_scene.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/file_contents.h"

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
  job.spec.sceneName = sceneFile.filename().string();
  job.spec.overrides = overrides;
  job.spec.frames = frames;
  // The coordinator and every worker build this scene again the same way (farm/job_scene.h).
  JobSceneOptions options;
  options.shownAs = sceneFile;
  options.overridesFrom = "command line";
  if (isModelFile(sceneFile)) {
    // A model rendered as it is: the farm gets the scene written for it (scene/scene_loader.h).
    job.scene = modelScene(sceneFile, job.spec.sceneJson, keep, camera);
    finishJobScene(job.scene, job.spec, options);
  } else {
    job.spec.sceneJson = readWholeFileOrThrow(sceneFile, sceneFile.string());
    if (camera) job.spec.sceneJson = withModelCamera(job.spec.sceneJson, sceneFile, *camera);
    job.scene = jobScene(job.spec, keep, options);
  }
  job.spec.assets = job.scene.assets;
  for (const auto& [path, sha] : job.scene.assets) job.assetBytes[sha] = std::move(read.at(path));
  return job;
}

}  // namespace lensfarm::cli
