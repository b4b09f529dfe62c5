#include "material/material.h"

#include "math/sampling.h"

namespace lensfarm {

const char* materialKindName(MaterialKind kind) {
  switch (kind) {
    case MaterialKind::kLambertian: return "lambertian";
    case MaterialKind::kMirror: return "mirror";
    case MaterialKind::kRippledMirror: return "rippled_mirror";
    case MaterialKind::kEmissive: return "emissive";
    case MaterialKind::kDielectric: return "dielectric";
    case MaterialKind::kConductor: return "conductor";
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

std::optional<MaterialSample> Material::sample(const Vec3& n, const Vec3& wo, Vec2 u, bool front) const {
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
    case MaterialKind::kConductor: {
      // A polished metal: the mirror direction, weighted by the conductor Fresnel term per
      // channel (grazing light reflects fully, at normal incidence F0 = ((eta-1)^2 + k^2) /
      // ((eta+1)^2 + k^2)), times the tint.
      const float cosO = glm::dot(n, wo);
      const Spectrum f(fresnelConductor(cosO, eta.r, k.r), fresnelConductor(cosO, eta.g, k.g),
                       fresnelConductor(cosO, eta.b, k.b));
      return MaterialSample{reflect(wo, n), albedo * f, 0.0f, true};
    }
    case MaterialKind::kDielectric: {
      // Reflect with probability F, refract otherwise: each branch's weight is then the tint
      // exactly (F / F, T / T), times 1/eta^2 on refraction: radiance is compressed into the
      // smaller solid angle of the denser side (Veach 1997, §5.2; pbrt-v4 DielectricBxDF), so a
      // glass object in a uniform field of radiance L shows L (tests: Dielectric.*).
      const float cosO = glm::dot(n, wo);  // n is on wo's side: > 0
      if (thinWalled) {
        // A pane: the two faces' reflections summed over its inter-reflections, R' = 2R/(1+R)
        // without absorption; light that passes leaves parallel to where it came from.
        float cosT;
        const float r = fresnelDielectric(cosO, ior, cosT);
        const float rPane = r < 1.0f ? 2.0f * r / (1.0f + r) : 1.0f;
        if (u.x < rPane) return MaterialSample{reflect(wo, n), albedo, 0.0f, true};
        return MaterialSample{-wo, albedo, 0.0f, true};
      }
      const float relative = front ? ior : 1.0f / ior;  // n_transmitted / n_incident
      float cosT;
      const float f = fresnelDielectric(cosO, relative, cosT);
      if (u.x < f) return MaterialSample{reflect(wo, n), albedo, 0.0f, true};
      // Snell: wi = -wo / relative + (cosO / relative - cosT) n, on the far side of the surface.
      const Vec3 wi = glm::normalize(-wo / relative + (cosO / relative - cosT) * n);
      return MaterialSample{wi, albedo / (relative * relative), 0.0f, true};
    }
  }
  return std::nullopt;
}

}  // namespace lensfarm
