#include "common/material/principled.h"

#include <algorithm>
#include <cmath>

#include "common/math/sampling.h"
#include "common/util/field_reader.h"

namespace lensfarm {

PrincipledBsdf::PrincipledBsdf(const PrincipledParams& params) : p_(params) {
  const float r = (p_.ior - 1.0f) / (p_.ior + 1.0f);
  const float f0 = std::min(1.0f, r * r * std::max(p_.specularColor, 0.0f));
  const float w = p_.transmission * (1.0f - p_.metallic);
  const bool straight =
      p_.thinWalled && w > 0.0f && GgxDistribution::alphaFromRoughness(p_.roughness) < GgxDistribution::kSmoothAlpha;
  if (!p_.thinWalled && w > 0.0f) {
    // The header's mixture: the glass share apart, the rest opaque with its metal share kept.
    glassWeight_ = w;
    glass_.emplace(p_.baseColor, p_.ior, false, p_.roughness);
    p_.transmission = 0.0f;
    p_.metallic = w < 1.0f ? std::min(1.0f, p_.metallic / (1.0f - w)) : 0.0f;
  }
  model_ = PrincipledModel{p_.baseColor.r,
                           p_.baseColor.g,
                           p_.baseColor.b,
                           p_.metallic,
                           p_.transmission,
                           p_.specular,
                           f0,
                           std::max(GgxDistribution::alphaFromRoughness(p_.roughness), GgxDistribution::kSmoothAlpha),
                           std::max(luminance(p_.baseColor), 0.0f),
                           straight ? 1.0f : 0.0f};
}

bool PrincipledBsdf::laneModel(PrincipledModel& model) const {
  if (glass_ || straight()) return false;
  model = model_;
  return true;
}

BsdfTraits PrincipledBsdf::traits() const {
  if (glass_) {
    if (glassWeight_ >= 1.0f) return glass_->traits();  // all glass: the dielectric's (delta when smooth)
    BsdfTraits t = BsdfTraits::glossyLobes(true, "principled (glTF) solid with transmission");
    t.transmits = true;
    return t;
  }
  // Black only when nothing can scatter: a black metal (F0 = 0 still reflects at grazing, but
  // C = 0 with metallic 1 reflects (1 - 0) x^5: not black). Every glTF material scatters something.
  const bool transmits = p_.transmission > 0.0f && p_.metallic < 1.0f;
  BsdfTraits t = BsdfTraits::glossyLobes(true, straight()  ? "principled (glTF) with thin-walled transmission"
                                               : transmits ? "principled (glTF) with transmission"
                                                           : "principled (glTF)");
  t.transmits = transmits;
  t.thinWall = straight();
  return t;
}

Spectrum PrincipledBsdf::evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  const Frame frame = Frame::fromNormal(n);
  const Spectrum opaque = glassWeight_ < 1.0f ? model_.evalLocal(frame.toLocal(wo), frame.toLocal(wi)) : Spectrum(0.0f);
  if (!glass_) return opaque;
  return glass_->evalCos(n, wo, wi, front) * glassWeight_ + opaque * (1.0f - glassWeight_);
}

float PrincipledBsdf::pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  const Frame frame = Frame::fromNormal(n);
  const float opaque = glassWeight_ < 1.0f ? model_.pdfLocal(frame.toLocal(wo), frame.toLocal(wi)) : 0.0f;
  if (!glass_) return opaque;
  return glassWeight_ * glass_->pdf(n, wo, wi, front) + (1.0f - glassWeight_) * opaque;
}

std::optional<MaterialSample> PrincipledBsdf::sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u,
                                                     bool front) const {
  if (glass_) {
    // One component by uLobe, which is then stretched back over [0, 1) for the component's own
    // choice; a non-delta sample is weighed by the whole mixture (one-sample MIS).
    std::optional<MaterialSample> s;
    if (uLobe < glassWeight_) {
      s = glass_->sample(n, wo, std::min(uLobe / glassWeight_, 0x1.fffffep-1f), u, front);
      if (!s || s->specular) return s;  // a delta: chosen with w, scattering w f: its own weight
    } else {
      s = sampleOpaque(n, wo, std::min((uLobe - glassWeight_) / (1.0f - glassWeight_), 0x1.fffffep-1f), u);
      if (!s) return s;
    }
    const float density = pdf(n, wo, s->wi, front);
    if (!(density > 0.0f)) return std::nullopt;
    const Spectrum f = evalCos(n, wo, s->wi, front);
    if (isBlack(f)) return std::nullopt;
    s->weight = f / density;
    s->pdf = density;
    return s;
  }
  return sampleOpaque(n, wo, uLobe, u);
}

std::optional<MaterialSample> PrincipledBsdf::sampleOpaque(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u) const {
  const Frame frame = Frame::fromNormal(n);
  const Vec3 woLocal = frame.toLocal(wo);
  if (!(woLocal.z > 0.0f)) return std::nullopt;
  const PrincipledModel::LobeChoice c = model_.lobes(woLocal.z);
  // A thin wall's smooth transmission first (Bsdf::straightProbability's convention): straight
  // through, weighed by its share of the choice; then diffuse and specular as for any surface.
  float choice = uLobe;
  if (straight()) {
    if (choice < c.transmission)
      return MaterialSample{-wo, straightAt(woLocal.z) / c.transmission, 0.0f, true, 1.0f, /*straight=*/true};
    choice -= c.transmission;
  }
  const Vec3 wiLocal = model_.sampleLocal(woLocal, c, choice, u);
  const float pdf = model_.pdfLocal(woLocal, wiLocal);
  if (!(pdf > 0.0f)) return std::nullopt;
  const Spectrum f = model_.evalLocal(woLocal, wiLocal);
  if (isBlack(f)) return std::nullopt;
  return MaterialSample{frame.toWorld(wiLocal), f / pdf, pdf, false};
}

Spectrum PrincipledBsdf::straightAt(float cosO) const {
  const float fd = p_.specular * (model_.f0 + (1.0f - model_.f0) * PrincipledModel::schlickWeight(cosO));
  return p_.baseColor * ((1.0f - p_.metallic) * p_.transmission * (1.0f - fd));
}

Spectrum PrincipledBsdf::straightTransmittance(const Vec3& n, const Vec3& wo) const {
  return straight() ? straightAt(std::abs(glm::dot(n, wo))) : Spectrum(0.0f);
}

float PrincipledBsdf::straightProbability(const Vec3& n, const Vec3& wo) const {
  return straight() ? model_.lobes(std::abs(glm::dot(n, wo))).transmission : 0.0f;
}

std::shared_ptr<const Bsdf> parsePrincipled(FieldReader& r) {
  PrincipledParams p;
  p.baseColor = r.color("base_color", Spectrum(1.0f), kReflectanceRange);
  p.metallic = float(r.number("metallic", 1.0, 0.0, 1.0));
  p.roughness = float(r.number("roughness", 1.0, 0.0, 1.0));
  p.transmission = float(r.number("transmission", 0.0, 0.0, 1.0));
  p.ior = float(r.number("ior", 1.5, 1.0, 10.0));
  p.specular = float(r.number("specular", 1.0, 0.0, 1.0));
  p.specularColor = luminance(r.color("specular_color", Spectrum(1.0f), kReflectanceRange));
  p.thinWalled = r.boolean("thin_walled", true);
  return std::make_shared<PrincipledBsdf>(p);
}

}  // namespace lensfarm
