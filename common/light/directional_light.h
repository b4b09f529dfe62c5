#pragma once
// A directional light, the sun (`lights` entry "type": "directional"): irradiance E arriving from
// `direction` (pointing from the scene towards the light) on a surface facing it.
//  - angular_diameter 0: a delta light, every point receives E cos(theta) from exactly that
//    direction; reached by light samples only.
//  - angular_diameter 2 theta_max > 0: a disk of uniform radiance L filling the cone of half-angle
//    theta_max about `direction`. A surface facing it receives
//        E = integral over the cone of L cos(theta) d omega = L 2 pi int_0^theta_max cos sin d theta
//          = L pi sin^2(theta_max),   so   L = E / (pi sin^2(theta_max));
//    it casts soft shadows, is seen by the camera and in mirrors, and is reached by escaped rays
//    (MIS against its light samples, which are uniform in the cone: pdf 1 / (2 pi (1 - cos theta_max))).
// Phi = pi r^2 E for the scene's bounding radius r (pbrt-v4's DistantLight::Phi), both kinds.
#include <memory>
#include <optional>
#include <string>

#include "common/light/light_source.h"

namespace lensfarm {

class DirectionalLight final : public LightSource {
 public:
  // toLight: unit direction towards the light; angularDiameter in degrees, in [0, 90].
  DirectionalLight(std::string name, const Vec3& toLight, const Spectrum& irradiance, double angularDiameter);

  const char* type() const override { return "directional"; }
  std::string describe() const override;
  bool isDelta() const override { return angularDiameter_ == 0.0; }
  bool isReachedByEscapedRays() const override { return !isDelta(); }
  double powerOverPi(const SceneSphere& sphere) const override;
  std::optional<LightSample> sample(const Vec3& ref, Vec2 u, const SceneSphere& sphere) const override;
  Spectrum escaped(const Vec3& d) const override { return inCone(d) ? radiance_ : Spectrum(0.0f); }
  float pdf(const Vec3& d) const override { return inCone(d) ? conePdf_ : 0.0f; }

  // The radiance of the disk (E / (pi sin^2 theta_max)); E itself for a delta light.
  const Spectrum& radiance() const { return radiance_; }

 private:
  // Within theta_max of the axis, judged by the sine (exact for small cones, where 1 - cos
  // is lost in float).
  bool inCone(const Vec3& d) const {
    const Vec3 c = glm::cross(d, toLight_);
    return glm::dot(d, toLight_) > 0.0f && glm::dot(c, c) <= sin2Max_;
  }

  Vec3 toLight_;
  Frame frame_;
  Spectrum irradiance_, radiance_;
  double angularDiameter_;
  float sin2Max_ = 0.0f, oneMinusCosMax_ = 0.0f, conePdf_ = 0.0f;
};

// "direction", "irradiance", "angular_diameter" (docs/scene-format.md, "lights").
std::shared_ptr<const LightSource> parseDirectionalLight(FieldReader& r, const LightParseContext& context);

}  // namespace lensfarm
