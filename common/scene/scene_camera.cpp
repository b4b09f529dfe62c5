#include "common/scene/scene_camera.h"

#include <cmath>

#include "common/camera/pinhole_camera.h"
#include "common/camera/real_lens_camera.h"
#include "common/camera/thin_lens_camera.h"

namespace lensfarm {

namespace {

// One row per camera model: whether the scene declares it, and how it is built. The first row
// that matches is the scene's camera.
struct CameraModel {
  const char* type;  // camera.type in the scene format
  bool (*declares)(const Scene&);
  std::unique_ptr<const Camera> (*make)(const Scene&);
};

constexpr CameraModel kCameraModels[] = {
    {"real_lens", [](const Scene& s) { return s.realLens.has_value(); },
     [](const Scene& s) -> std::unique_ptr<const Camera> {
       return std::make_unique<RealLensCamera>(s.cameraParams, *s.realLens, s.render.width, s.render.height);
     }},
    {"pinhole", [](const Scene& s) { return std::isinf(s.cameraParams.fNumber); },
     [](const Scene& s) -> std::unique_ptr<const Camera> { return std::make_unique<PinholeCamera>(s.camera()); }},
    {"thin_lens", [](const Scene&) { return true; },
     [](const Scene& s) -> std::unique_ptr<const Camera> { return std::make_unique<ThinLensCamera>(s.camera()); }},
};

}  // namespace

std::unique_ptr<const Camera> declaredCamera(const Scene& scene) {
  for (const CameraModel& model : kCameraModels)
    if (model.declares(scene)) return model.make(scene);
  return nullptr;  // (the last row declares every scene)
}

std::unique_ptr<const Camera> renderCamera(std::unique_ptr<const Camera> declared, const EffectSet& effects) {
  if (dynamic_cast<const ThinLensCamera*>(declared.get()) && !effects.depthOfField)
    return std::make_unique<PinholeCamera>(declared->paraxial());
  return declared;
}

}  // namespace lensfarm
