#pragma once
// Perfect mirrors (2013 report §4.2): the ideal mirror, and the report's rippled glass mirror, which
// reflects about a randomly tilted normal. Both are delta-like for the integrator: no light
// sampling, and their bounces do not count toward B unless the scene says so (the report's §4.5).
#include <memory>

#include "common/material/bsdf.h"

namespace lensfarm {

class FieldReader;

// Specular reflection, weight = reflectance.
class MirrorBsdf final : public Bsdf {
 public:
  explicit MirrorBsdf(const Spectrum& reflectance) : reflectance_(reflectance) {}
  BsdfTraits traits() const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;

 private:
  Spectrum reflectance_;
};

// The 2013 report's rippled mirror: reflection about the normal tilted by a random slope (tan) of at
// most `ripple`, uniform over the disk of slopes; weight = reflectance.
class RippledMirrorBsdf final : public Bsdf {
 public:
  RippledMirrorBsdf(const Spectrum& reflectance, float ripple) : reflectance_(reflectance), ripple_(ripple) {}
  BsdfTraits traits() const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;

 private:
  Spectrum reflectance_;
  float ripple_;
};

// `mirror`: reflectance. `rippled_mirror`: reflectance, ripple (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseMirror(FieldReader& r);
std::shared_ptr<const Bsdf> parseRippledMirror(FieldReader& r);

}  // namespace lensfarm
