#include "material/dielectric.h"

#include "material/fresnel.h"
#include "scene/field_reader.h"

namespace lensfarm {

BsdfTraits DielectricBsdf::traits() const { return BsdfTraits::deltaLobes(tint_, "glass"); }

std::optional<MaterialSample> DielectricBsdf::sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 /*u*/,
                                                     bool front) const {
  // Reflect with probability F, refract otherwise: each branch's weight is then the tint exactly
  // (F / F, T / T), times 1/eta^2 on refraction (tests: Dielectric.*).
  const float cosO = glm::dot(n, wo);  // n is on wo's side: >= 0
  if (thinWalled_) {
    // A pane: the two faces' reflections summed over its inter-reflections, R' = 2R/(1+R) without
    // absorption; light that passes leaves parallel to where it came from.
    float cosT;
    const float r = fresnelDielectric(cosO, ior_, cosT);
    const float rPane = r < 1.0f ? 2.0f * r / (1.0f + r) : 1.0f;
    if (uLobe < rPane) return MaterialSample{reflect(wo, n), tint_, 0.0f, true};
    return MaterialSample{-wo, tint_, 0.0f, true};
  }
  const float relative = front ? ior_ : 1.0f / ior_;  // n_transmitted / n_incident
  float cosT;
  const float f = fresnelDielectric(cosO, relative, cosT);
  if (uLobe < f) return MaterialSample{reflect(wo, n), tint_, 0.0f, true};
  // Snell: wi = -wo / relative + (cosO / relative - cosT) n, on the far side of the surface.
  const Vec3 wi = glm::normalize(-wo / relative + (cosO / relative - cosT) * n);
  return MaterialSample{wi, tint_ / (relative * relative), 0.0f, true};
}

std::shared_ptr<const Bsdf> parseDielectric(FieldReader& r) {
  const Spectrum transmittance = r.color("transmittance", Spectrum(1.0f), kReflectanceRange);
  const float ior = float(r.number("ior", 1.5, 1.0, 10.0));
  return std::make_shared<DielectricBsdf>(transmittance, ior, r.boolean("thin_walled", false));
}

}  // namespace lensfarm
