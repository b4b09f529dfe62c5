#include "common/farm/job_scene.h"

#include "common/scene/render_overrides.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
std::string shown(const JobSpec& spec, const JobSceneOptions& options) {
  return options.shownAs.empty() ? spec.sceneName : options.shownAs.string();
}
}  // namespace

Scene jobScene(const JobSpec& spec, const AssetReader& readAsset, const JobSceneOptions& options) {
  const std::filesystem::path file = options.shownAs.empty() ? std::filesystem::path(spec.sceneName) : options.shownAs;
  Scene scene = parseScene(spec.sceneJson, file, readAsset, options.frame);
  finishJobScene(scene, spec, options);
  return scene;
}

void finishJobScene(Scene& scene, const JobSpec& spec, const JobSceneOptions& options) {
  const std::string name = shown(spec, options);
  applyOverrides(spec.overrides, scene.render, options.overridesFrom.empty() ? name : options.overridesFrom);
  try {
    (void)scene.camera();  // the camera at the final resolution
  } catch (const InputError& e) {
    throw InputError(name, std::string("camera.") + e.what());
  }
  if (!spec.frames) return;
  if (scene.render.convergenceDriven())
    throw InputError(name,
                     "target_error / time_limit (--target-error, --deadline): an animation renders every frame "
                     "to its samples; give samples_per_pixel alone");
  if (scene.render.adaptive.enabled)
    throw InputError(name,
                     "adaptive: an animation renders every frame uniformly; adaptive sampling is for stills "
                     "(give adaptive false, or render the frames one job each)");
}

}  // namespace lensfarm
