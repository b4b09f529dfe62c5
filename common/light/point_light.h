#pragma once
// A point light (`lights` entry "type": "point"): radiant intensity I (light/light_source.h,
// units) from one point in every direction; a point at distance r receives I cos(theta) / r^2.
// A delta light: reached by light samples only (not seen by the camera, nor in mirrors).
#include <memory>
#include <optional>
#include <string>

#include "common/light/light_source.h"

namespace lensfarm {

// The light sample of a point at `position` sending intensity I towards `ref`: radiance I / r^2
// with density 1 (a delta light). Nothing where ref is the point itself.
inline std::optional<LightSample> pointLightSample(const Vec3& position, const Spectrum& intensity, const Vec3& ref) {
  const Vec3 d = position - ref;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > 0.0f)) return std::nullopt;
  // n zero: the shadow ray ends at the point itself.
  return LightSample{position, Vec3(0.0f), position, 0.0f, intensity / dist2, 1.0f, true, 1.0f};
}

// Spectrum as "[r, g, b]" (or one number where all are equal), for what lights describe.
std::string describeSpectrum(const Spectrum& s);

class PointLight final : public LightSource {
 public:
  PointLight(std::string name, const Vec3& position, const Spectrum& intensity)
      : LightSource(std::move(name)), position_(position), intensity_(intensity) {}

  const char* type() const override { return "point"; }
  std::string describe() const override { return "intensity " + describeSpectrum(intensity_); }
  bool isDelta() const override { return true; }
  // Phi = 4 pi I.
  double powerOverPi(const SceneSphere&) const override { return 4.0 * double(luminance(intensity_)); }
  std::optional<LightSample> sample(const Vec3& ref, Vec2, const SceneSphere&) const override {
    return pointLightSample(position_, intensity_, ref);
  }
  std::optional<Vec3> position() const override { return position_; }
  // Intensity I in every direction: normals over the whole sphere, each emitting over its hemisphere.
  std::optional<LightBounds> bounds() const override {
    return LightBounds{position_, position_, luminance(intensity_), DirectionCone::sphere(), 0.0f, false};
  }

 private:
  Vec3 position_;  // render space
  Spectrum intensity_;
};

// "position", "intensity" (docs/scene-format.md, "lights").
std::shared_ptr<const LightSource> parsePointLight(FieldReader& r, const LightParseContext& context);

}  // namespace lensfarm
