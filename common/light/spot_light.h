#pragma once
// A spot light (`lights` entry "type": "spot"): a point light (light/point_light.h) whose
// intensity I is full within `falloff_start` of its axis, falls off with a smoothstep in
// cos(theta) out to `cone_angle` and is zero beyond, as pbrt-v4's SpotLight (Pharr, Jakob,
// Humphreys, "Physically Based Rendering", 4th ed. §12.2.1):
//     I(theta) = I smoothstep(cos(cone_angle), cos(falloff_start), cos(theta)).
// A delta light: reached by light samples only.
#include <memory>
#include <optional>
#include <string>

#include "common/light/point_light.h"

namespace lensfarm {

// Hermite smoothstep of x between a (0) and b (1); a step at a where a == b (pbrt-v4's SmoothStep).
inline float smoothStep(float a, float b, float x) {
  if (a == b) return x < a ? 0.0f : 1.0f;
  const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

class SpotLight final : public LightSource {
 public:
  // axis: unit direction the spot points in; angles in degrees, 0 <= falloffStart <= coneAngle <= 90.
  SpotLight(std::string name, const Vec3& position, const Vec3& axis, const Spectrum& intensity, double coneAngle,
            double falloffStart);

  const char* type() const override { return "spot"; }
  std::string describe() const override;
  bool isDelta() const override { return true; }
  // Phi = 2 pi I (1 - (cos falloff_start + cos cone_angle) / 2) (pbrt-v4's SpotLight::Phi).
  double powerOverPi(const SceneSphere&) const override;
  std::optional<LightSample> sample(const Vec3& ref, Vec2, const SceneSphere&) const override;
  std::optional<Vec3> position() const override { return position_; }
  // Full intensity within falloff_start of the axis, some out to cone_angle (pbrt-v4's SpotLight::Bounds).
  std::optional<LightBounds> bounds() const override;

  // The fraction of I sent in direction w (unit, from the light).
  float falloff(const Vec3& w) const { return smoothStep(cosTotal_, cosFalloffStart_, glm::dot(axis_, w)); }

 private:
  Vec3 position_, axis_;
  Spectrum intensity_;
  double coneAngle_, falloffStart_;
  float cosTotal_, cosFalloffStart_;
};

// "position", "look_at" or "direction", "intensity", "cone_angle", "falloff_start"
// (docs/scene-format.md, "lights").
std::shared_ptr<const LightSource> parseSpotLight(FieldReader& r, const LightParseContext& context);

}  // namespace lensfarm
