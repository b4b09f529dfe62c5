#pragma once
// Everything a render needs, built once per scene and shared read-only by all threads:
// the scene, its camera at the render resolution, the Embree scene and the light sampler.
#include "camera/thin_lens_camera.h"
#include "light/light_sampler.h"
#include "render/ray_caster.h"
#include "scene/scene.h"

namespace lensfarm {

class RenderScene {
 public:
  explicit RenderScene(const Scene& scene)
      : scene_(scene), camera_(scene.camera()), caster_(scene), lights_(scene, caster_) {}

  const Scene& scene() const { return scene_; }
  const RenderSettings& settings() const { return scene_.render; }
  const ThinLensCamera& camera() const { return camera_; }
  const RayCaster& caster() const { return caster_; }
  const LightSampler& lights() const { return lights_; }
  const Material& material(uint32_t id) const { return scene_.materials[id]; }

 private:
  const Scene& scene_;
  ThinLensCamera camera_;
  RayCaster caster_;
  LightSampler lights_;
};

}  // namespace lensfarm
