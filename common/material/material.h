#pragma once
// Surface materials (seed §4.2, §4.5.1).
//
// All materials shade both sides of a surface: callers pass the geometric normal flipped to the
// side the light leaves towards (`n` below, dot(n, wo) > 0). Emission is one-sided (front face,
// the face whose normal is cross(v1 - v0, v2 - v0)) unless `twoSidedEmission` is set.
//
// Colour mixing is the seed's eq. 2: reflected = incident * albedo, channel by channel.
#include <optional>
#include <string>

#include "math/sampling.h"
#include "math/vec.h"

namespace lensfarm {

enum class MaterialKind {
  kLambertian,     // perfectly diffuse, f = albedo / pi
  kMirror,         // perfect specular reflection, weight = reflectance
  kRippledMirror,  // the seed's rippled glass mirror: specular about a randomly tilted normal
  kEmissive,       // a light: emits `emission`, reflects nothing
};

const char* materialKindName(MaterialKind kind);

// The outcome of sampling a material: the direction light arrives from (wi, pointing away from
// the surface) and the path throughput weight f cos / pdf.
// The Lambertian lobe's formulas, inline so the integrator's lane loops (math/lanes.h) evaluate
// exactly what evalCos and pdf do.
inline Spectrum lambertianEvalCos(const Spectrum& albedo, const Vec3& n, const Vec3& wi) {
  const float cosTheta = glm::dot(n, wi);
  return cosTheta > 0.0f ? albedo * (cosTheta * kInvPi) : Spectrum(0.0f);
}
inline float lambertianPdf(const Vec3& n, const Vec3& wi) { return cosineHemispherePdf(glm::dot(n, wi)); }

struct MaterialSample {
  Vec3 wi;
  Spectrum weight;
  float pdf;      // solid-angle density; 0 for specular (delta) lobes
  bool specular;  // a delta lobe: no light sampling, no MIS
};

struct Material {
  std::string name;
  MaterialKind kind = MaterialKind::kLambertian;
  Spectrum albedo{0.0f};       // diffuse albedo, or mirror reflectance (the seed's attenuation)
  float ripple = 0.0f;         // rippled mirror: largest tilt of the normal, as a slope (tan)
  Spectrum emission{0.0f};     // emitted radiance
  bool twoSidedEmission = false;

  bool isEmissive() const { return !isBlack(emission); }
  bool isSpecular() const { return kind == MaterialKind::kMirror || kind == MaterialKind::kRippledMirror; }
  bool reflects() const { return kind != MaterialKind::kEmissive && !isBlack(albedo); }

  // f(wo, wi) cos(theta_i) for non-specular materials (zero for specular ones).
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi) const;
  // Density of sample() returning wi, in solid angle (zero for specular ones).
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi) const;
  // Samples an incident direction from u in [0,1)^2; nothing when the material reflects nothing.
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, Vec2 u) const;
  // sample() for a scene without specular materials: Lambertian or nothing, without the switch.
  std::optional<MaterialSample> sampleLambertian(const Vec3& n, Vec2 u) const;
};

}  // namespace lensfarm
