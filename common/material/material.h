#pragma once
// Surface materials (seed §4.2, §4.5.1).
//
// All materials shade both sides of a surface: callers pass the geometric normal flipped to the
// side the light leaves towards (`n` below, dot(n, wo) > 0). Emission is one-sided (front face,
// the face whose normal is cross(v1 - v0, v2 - v0)) unless `twoSidedEmission` is set.
//
// Colour mixing is the seed's eq. 2: reflected = incident * albedo, channel by channel.
#include <algorithm>
#include <cmath>
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
  kDielectric,     // smooth glass: Fresnel reflection and refraction (Snell), or a thin-walled pane
  kConductor,      // smooth metal: specular reflection weighted by the conductor Fresnel term
};

// Fresnel reflectance of a smooth conductor of complex index eta + i k (relative to the outside
// medium, air) for unpolarised light at cosine cosI (pbrt-v3 FrConductor; Born & Wolf §14.2).
inline float fresnelConductor(float cosI, float eta, float k) {
  cosI = std::min(1.0f, std::abs(cosI));
  const float cos2 = cosI * cosI, sin2 = 1.0f - cos2;
  const float eta2 = eta * eta, k2 = k * k;
  const float t0 = eta2 - k2 - sin2;
  const float a2b2 = std::sqrt(t0 * t0 + 4.0f * eta2 * k2);
  const float t1 = a2b2 + cos2;
  const float a = std::sqrt(std::max(0.0f, 0.5f * (a2b2 + t0)));
  const float t2 = 2.0f * cosI * a;
  const float rs = (t1 - t2) / (t1 + t2);
  const float t3 = cos2 * a2b2 + sin2 * sin2;
  const float t4 = t2 * sin2;
  const float rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5f * (rs + rp);
}

// Fresnel reflectance of a smooth dielectric boundary for unpolarised light (the mean of the s
// and p reflectances, Born & Wolf §1.5.2), at cosine cosI of the incident direction with the
// normal on its side and relative index eta = n_transmitted / n_incident. 1 beyond the critical
// angle (total internal reflection). cosTransmitted receives |cos| of the refracted direction.
inline float fresnelDielectric(float cosI, float eta, float& cosTransmitted) {
  cosI = std::min(1.0f, std::abs(cosI));
  const float sin2T = (1.0f - cosI * cosI) / (eta * eta);
  if (sin2T >= 1.0f) {
    cosTransmitted = 0.0f;
    return 1.0f;
  }
  const float cosT = std::sqrt(1.0f - sin2T);
  const float rParallel = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rPerpendicular = (cosI - eta * cosT) / (cosI + eta * cosT);
  cosTransmitted = cosT;
  return 0.5f * (rParallel * rParallel + rPerpendicular * rPerpendicular);
}

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
  float ior = 1.5f;            // dielectric: index of refraction inside (the front face's back side)
  bool thinWalled = false;     // dielectric: a pane of negligible thickness (no bending)
  Spectrum eta{1.0f}, k{0.0f}; // conductor: complex index of refraction per RGB channel
  Spectrum emission{0.0f};     // emitted radiance
  bool twoSidedEmission = false;

  bool isEmissive() const { return !isBlack(emission); }
  bool isSpecular() const {
    return kind == MaterialKind::kMirror || kind == MaterialKind::kRippledMirror || kind == MaterialKind::kDielectric ||
           kind == MaterialKind::kConductor;
  }
  bool reflects() const { return kind != MaterialKind::kEmissive && !isBlack(albedo); }

  // f(wo, wi) cos(theta_i) for non-specular materials (zero for specular ones).
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi) const;
  // Density of sample() returning wi, in solid angle (zero for specular ones).
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi) const;
  // Samples an incident direction from u in [0,1)^2; nothing when the material reflects nothing.
  // `front`: wo is on the front side of the geometric normal (outside a dielectric).
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, Vec2 u, bool front = true) const;
  // sample() for a scene without specular materials: Lambertian or nothing, without the switch.
  std::optional<MaterialSample> sampleLambertian(const Vec3& n, Vec2 u) const;
};

}  // namespace lensfarm
