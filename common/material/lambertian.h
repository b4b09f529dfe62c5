#pragma once
// The perfectly diffuse surface of the 2013 report (§4.2): f = albedo / pi, sampled cosine-weighted so a
// sample's weight is the albedo exactly.
#include <memory>

#include "common/material/bsdf.h"
#include "common/math/sampling.h"

namespace lensfarm {

class FieldReader;

// The lobe's formulas, inline so the integrator's lane loops (math/lanes.h) evaluate exactly what
// LambertianBsdf::evalCos and pdf do.
inline Spectrum lambertianEvalCos(const Spectrum& albedo, const Vec3& n, const Vec3& wi) {
  const float cosTheta = glm::dot(n, wi);
  return cosTheta > 0.0f ? albedo * (cosTheta * kInvPi) : Spectrum(0.0f);
}
inline float lambertianPdf(const Vec3& n, const Vec3& wi) { return cosineHemispherePdf(glm::dot(n, wi)); }
// Cosine-weighted: f cos / pdf = albedo exactly; nothing where the direction is not above n.
inline std::optional<MaterialSample> sampleLambertian(const Spectrum& albedo, const Vec3& n, Vec2 u) {
  const Vec3 local = sampleCosineHemisphere(u);
  if (local.z <= 0.0f) return std::nullopt;
  return MaterialSample{Frame::fromNormal(n).toWorld(local), albedo, cosineHemispherePdf(local.z), false};
}

class LambertianBsdf final : public Bsdf {
 public:
  explicit LambertianBsdf(const Spectrum& albedo) : albedo_(albedo) {}
  BsdfTraits traits() const override;
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;

 private:
  Spectrum albedo_;
};

// `lambertian`: albedo (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseLambertian(FieldReader& r);

}  // namespace lensfarm
