#pragma once
// The environment as a light (the scene's top-level "environment", docs/scene-format.md): an
// EnvironmentMap (light/environment_map.h, which owns the equirectangular convention) of constant
// radiance or from an OpenEXR image. Reached by light samples (importance sampled by luminance x
// solid angle) and by every ray that leaves the scene, weighed by MIS; Phi = pi r^2 times the
// integral of its luminance over the sphere (pbrt-v4's ImageInfiniteLight::Phi).
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "common/light/environment_map.h"
#include "common/light/light_source.h"
#include "common/util/asset_loader.h"

namespace lensfarm {

class EnvironmentLight final : public LightSource {
 public:
  // source: what it was made from, for describe() ("sky.exr" or "" for a constant).
  EnvironmentLight(std::string source, std::shared_ptr<const EnvironmentMap> map);

  const char* type() const override { return "environment"; }
  std::string describe() const override;
  bool isDelta() const override { return false; }
  bool isReachedByEscapedRays() const override { return true; }
  double powerOverPi(const SceneSphere& sphere) const override;
  std::optional<LightSample> sample(const Vec3& ref, Vec2 u, const SceneSphere& sphere) const override;
  Spectrum escaped(const Vec3& d) const override { return map_->eval(d); }
  float pdf(const Vec3& d) const override { return map_->pdf(d); }

  const EnvironmentMap& map() const { return *map_; }

 private:
  std::string source_;
  std::shared_ptr<const EnvironmentMap> map_;
};

// The scene's "environment" object: {"radiance": colour} or {"file": path, "strength": s,
// "rotation": degrees}. Errors are InputErrors naming the field: "environment.file: pixel (12, 7)
// red is NaN".
std::shared_ptr<const LightSource> parseEnvironment(FieldReader& r, const AssetLoader& load);

}  // namespace lensfarm
