#include "material/material.h"

#include "math/sampling.h"

namespace lensfarm {

const char* materialKindName(MaterialKind kind) {
  switch (kind) {
    case MaterialKind::kLambertian: return "lambertian";
    case MaterialKind::kMirror: return "mirror";
    case MaterialKind::kRippledMirror: return "rippled_mirror";
    case MaterialKind::kEmissive: return "emissive";
  }
  return "?";
}

namespace {
Vec3 reflect(const Vec3& wo, const Vec3& n) { return 2.0f * glm::dot(wo, n) * n - wo; }
}  // namespace

Spectrum Material::evalCos(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi) const {
  if (kind != MaterialKind::kLambertian) return Spectrum(0.0f);
  return lambertianEvalCos(albedo, n, wi);
}

float Material::pdf(const Vec3& n, const Vec3& /*wo*/, const Vec3& wi) const {
  if (kind != MaterialKind::kLambertian) return 0.0f;
  return lambertianPdf(n, wi);
}

std::optional<MaterialSample> Material::sampleLambertian(const Vec3& n, Vec2 u) const {
  if (kind != MaterialKind::kLambertian) return std::nullopt;
  // Cosine-weighted: f cos / pdf = albedo exactly.
  const Vec3 local = sampleCosineHemisphere(u);
  if (local.z <= 0.0f) return std::nullopt;
  return MaterialSample{Frame::fromNormal(n).toWorld(local), albedo, cosineHemispherePdf(local.z), false};
}

std::optional<MaterialSample> Material::sample(const Vec3& n, const Vec3& wo, Vec2 u) const {
  switch (kind) {
    case MaterialKind::kLambertian:
      return sampleLambertian(n, u);
    case MaterialKind::kMirror:
      return MaterialSample{reflect(wo, n), albedo, 0.0f, true};
    case MaterialKind::kRippledMirror: {
      // Reflect about a normal tilted by a random slope of at most `ripple` (a rippled glass
      // surface), then fold any direction that would leave below the surface back above it.
      // The fold keeps every ray (energy = albedo exactly) and the direction strictly in the
      // upper hemisphere, however grazing wo is.
      const Frame frame = Frame::fromNormal(n);
      const Vec2 slope = sampleConcentricDisk(u) * ripple;
      const Vec3 tilted = glm::normalize(frame.toWorld(Vec3(slope.x, slope.y, 1.0f)));
      Vec3 wi = reflect(wo, tilted);
      const float below = glm::dot(wi, n);
      if (below < 0.0f) wi -= 2.0f * below * n;
      return MaterialSample{glm::normalize(wi), albedo, 0.0f, true};
    }
    case MaterialKind::kEmissive:
      return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace lensfarm
