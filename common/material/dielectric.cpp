#include "common/material/dielectric.h"

#include "common/material/fresnel.h"
#include "common/util/field_reader.h"

namespace lensfarm {

DielectricBsdf::DielectricBsdf(const Spectrum& transmittance, float ior, bool thinWalled, float roughness)
    : tint_(transmittance), ior_(ior), thinWalled_(thinWalled), ggx_{GgxDistribution::alphaFromRoughness(roughness)} {
  smooth_ = thinWalled || roughness <= 0.0f || ggx_.isEffectivelySmooth();
}

BsdfTraits DielectricBsdf::traits() const {
  BsdfTraits t = smooth_ ? BsdfTraits::deltaLobes(tint_, thinWalled_ ? "thin glass" : "glass", /*choosesLobe=*/true)
                         : BsdfTraits::glossyLobes(!isBlack(tint_), "rough glass");
  t.transmits = true;
  t.thinWall = thinWalled_;
  return t;
}

namespace {
// A pane's reflectance summed over its inter-reflections without absorption: R' = 2R / (1 + R).
float paneReflectance(float cosO, float ior) {
  float cosT;
  const float r = fresnelDielectric(cosO, ior, cosT);
  return r < 1.0f ? 2.0f * r / (1.0f + r) : 1.0f;
}
}  // namespace

Spectrum DielectricBsdf::straightTransmittance(const Vec3& n, const Vec3& wo) const {
  return tint_ * straightProbability(n, wo);
}

float DielectricBsdf::straightProbability(const Vec3& n, const Vec3& wo) const {
  return thinWalled_ ? 1.0f - paneReflectance(std::abs(glm::dot(n, wo)), ior_) : 0.0f;
}

void DielectricBsdf::evalLocal(const Vec3& wo, const Vec3& wi, float eta, Spectrum* f, float* pdf) const {
  *f = Spectrum(0.0f);
  *pdf = 0.0f;
  if (!(wo.z > 0.0f) || wi.z == 0.0f) return;
  const bool reflection = wi.z > 0.0f;
  // The (generalised) half vector, on wo's side.
  Vec3 m = reflection ? wo + wi : eta * wi + wo;
  const float length = glm::length(m);
  if (!(length > 0.0f)) return;
  m /= length;
  if (m.z < 0.0f) m = -m;
  const float om = glm::dot(wo, m), im = glm::dot(wi, m);
  // Microfacets seen from behind by either direction contribute nothing.
  if (om <= 0.0f || (reflection ? im <= 0.0f : im >= 0.0f)) return;
  float cosT;
  const float fr = fresnelDielectric(om, eta, cosT);
  const float visible = ggx_.pdfVisibleNormal(wo, m);  // D_wo(m)
  if (reflection) {
    *f = tint_ * (fr * ggx_.D(m) * ggx_.G(wo, wi) / (4.0f * wo.z));
    *pdf = fr * visible / (4.0f * om);
  } else {
    const float denom = im + om / eta;
    const float jacobian = std::abs(im) / (denom * denom);  // dm / dwi
    *f = tint_ * ((1.0f - fr) * ggx_.D(m) * ggx_.G(wo, wi) * std::abs(im) * om / (wo.z * denom * denom * eta * eta));
    *pdf = (1.0f - fr) * visible * jacobian;
  }
}

Spectrum DielectricBsdf::evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  if (smooth_) return Spectrum(0.0f);
  const Frame frame = Frame::fromNormal(n);
  Spectrum f;
  float p;
  evalLocal(frame.toLocal(wo), frame.toLocal(wi), front ? ior_ : 1.0f / ior_, &f, &p);
  return f;
}

float DielectricBsdf::pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  if (smooth_) return 0.0f;
  const Frame frame = Frame::fromNormal(n);
  Spectrum f;
  float p;
  evalLocal(frame.toLocal(wo), frame.toLocal(wi), front ? ior_ : 1.0f / ior_, &f, &p);
  return p;
}

std::optional<MaterialSample> DielectricBsdf::sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u,
                                                     bool front) const {
  if (!smooth_) {
    const float eta = front ? ior_ : 1.0f / ior_;
    const Frame frame = Frame::fromNormal(n);
    const Vec3 woLocal = frame.toLocal(wo);
    if (!(woLocal.z > 0.0f)) return std::nullopt;
    const Vec3 m = ggx_.sampleVisibleNormal(woLocal, u);
    const float om = glm::dot(woLocal, m);
    if (!(om > 0.0f)) return std::nullopt;
    float cosT;
    const float fr = fresnelDielectric(om, eta, cosT);
    // Reflect off m with probability F, else refract through it (Snell about m).
    const bool reflection = uLobe < fr;
    const Vec3 wiLocal = reflection ? reflect(woLocal, m) : glm::normalize(-woLocal / eta + (om / eta - cosT) * m);
    // A reflection that leaves below the surface, or a refraction above it, is masked: absorbed
    // (its direction belongs to the other branch, whose density does not include this path).
    if (reflection != (wiLocal.z > 0.0f)) return std::nullopt;
    Spectrum f;
    float pdf;
    evalLocal(woLocal, wiLocal, eta, &f, &pdf);
    if (!(pdf > 0.0f) || isBlack(f)) return std::nullopt;  // left on the wrong side: masked, absorbed
    return MaterialSample{frame.toWorld(wiLocal), f / pdf, pdf, false, reflection ? 1.0f : eta};
  }
  // Reflect with probability F, refract otherwise: each branch's weight is then the tint exactly
  // (F / F, T / T), times 1/eta^2 on refraction (tests: Dielectric.*).
  const float cosO = glm::dot(n, wo);  // n is on wo's side: >= 0
  if (thinWalled_) {
    // A pane: the two faces' reflections summed over its inter-reflections, R' = 2R/(1+R) without
    // absorption; light that passes leaves parallel to where it came from.
    // Straight through first (Bsdf::straightProbability's convention), else reflected.
    if (uLobe < 1.0f - paneReflectance(cosO, ior_))
      return MaterialSample{-wo, tint_, 0.0f, true, 1.0f, /*straight=*/true};
    return MaterialSample{reflect(wo, n), tint_, 0.0f, true};
  }
  const float relative = front ? ior_ : 1.0f / ior_;  // n_transmitted / n_incident
  float cosT;
  const float f = fresnelDielectric(cosO, relative, cosT);
  if (uLobe < f) return MaterialSample{reflect(wo, n), tint_, 0.0f, true};
  // Snell: wi = -wo / relative + (cosO / relative - cosT) n, on the far side of the surface.
  const Vec3 wi = glm::normalize(-wo / relative + (cosO / relative - cosT) * n);
  return MaterialSample{wi, tint_ / (relative * relative), 0.0f, true, relative};
}

std::shared_ptr<const Bsdf> parseDielectric(FieldReader& r) {
  const Spectrum transmittance = r.color("transmittance", Spectrum(1.0f), kReflectanceRange);
  const float ior = float(r.number("ior", 1.5, 1.0, 10.0));
  const bool thinWalled = r.boolean("thin_walled", false);
  const float roughness = float(r.number("roughness", 0.0, 0.0, 1.0));
  if (thinWalled && roughness > 0.0f)
    r.fail(r.field("roughness"), "a thin_walled pane is smooth: roughness must be 0 (or drop thin_walled)");
  return std::make_shared<DielectricBsdf>(transmittance, ior, thinWalled, roughness);
}

}  // namespace lensfarm
