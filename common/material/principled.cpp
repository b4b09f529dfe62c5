#include "common/material/principled.h"

#include <algorithm>
#include <cmath>

#include "common/math/sampling.h"
#include "common/util/field_reader.h"

namespace lensfarm {

namespace {
float schlickWeight(float cosI) {
  const float m = 1.0f - std::min(1.0f, std::abs(cosI)), m2 = m * m;
  return m2 * m2 * m;
}
// The surface's mirror image of a direction below it.
Vec3 mirrored(const Vec3& w) { return Vec3(w.x, w.y, -w.z); }
}  // namespace

PrincipledBsdf::PrincipledBsdf(const PrincipledParams& params)
    : p_(params), ggx_{std::max(GgxDistribution::alphaFromRoughness(params.roughness), GgxDistribution::kSmoothAlpha)} {
  const float r = (p_.ior - 1.0f) / (p_.ior + 1.0f);
  f0_ = std::min(1.0f, r * r * std::max(p_.specularColor, 0.0f));
  const float w = p_.transmission * (1.0f - p_.metallic);
  straight_ =
      p_.thinWalled && w > 0.0f && GgxDistribution::alphaFromRoughness(p_.roughness) < GgxDistribution::kSmoothAlpha;
  if (!p_.thinWalled && w > 0.0f) {
    // The header's mixture: the glass share apart, the rest opaque with its metal share kept.
    glassWeight_ = w;
    glass_.emplace(p_.baseColor, p_.ior, false, p_.roughness);
    p_.transmission = 0.0f;
    p_.metallic = w < 1.0f ? std::min(1.0f, p_.metallic / (1.0f - w)) : 0.0f;
  }
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
  BsdfTraits t = BsdfTraits::glossyLobes(true, straight_   ? "principled (glTF) with thin-walled transmission"
                                               : transmits ? "principled (glTF) with transmission"
                                                           : "principled (glTF)");
  t.transmits = transmits;
  t.thinWall = straight_;
  return t;
}

PrincipledBsdf::LobeChoice PrincipledBsdf::lobes(float cosO) const {
  const float fd = p_.specular * (f0_ + (1.0f - f0_) * schlickWeight(cosO));
  const float metal = p_.metallic;
  const float dielectric = 1.0f - p_.metallic;
  const float colour = std::max(luminance(p_.baseColor), 0.0f);
  const float specular = metal + dielectric * fd;
  const float diffuse = dielectric * (1.0f - fd) * (1.0f - p_.transmission) * colour;
  const float transmission = dielectric * (1.0f - fd) * p_.transmission * colour;
  const float total = specular + diffuse + transmission;
  if (!(total > 0.0f)) return {1.0f, 0.0f, 0.0f};
  return {specular / total, diffuse / total, transmission / total};
}

Spectrum PrincipledBsdf::evalLocal(const Vec3& wo, const Vec3& wi) const {
  if (!(wo.z > 0.0f) || wi.z == 0.0f) return Spectrum(0.0f);
  const bool reflection = wi.z > 0.0f;
  const Vec3 wr = reflection ? wi : mirrored(wi);
  const Vec3 sum = wo + wr;
  const float length = glm::length(sum);
  if (!(length > 0.0f)) return Spectrum(0.0f);
  const Vec3 h = sum / length;
  const float vh = glm::dot(wo, h);
  const float lobe = ggxReflectionCos(ggx_, wo, wr, h);  // specular_brdf(alpha) cos_i
  // KHR_materials_specular: the dielectric's Fresnel term times specularFactor, in the layer and
  // in the base's weight alike.
  const float fd = p_.specular * (f0_ + (1.0f - f0_) * schlickWeight(vh));
  const float baseWeight =
      1.0f - p_.specular * (f0_ + (1.0f - f0_) * schlickWeight(wo.z));  // see the header: 1 - F_d(N.V)
  const float dielectric = 1.0f - p_.metallic;
  if (!reflection)
    return straight_ ? Spectrum(0.0f) : p_.baseColor * (dielectric * p_.transmission * baseWeight * lobe);
  const Spectrum metalFresnel = p_.baseColor + (Spectrum(1.0f) - p_.baseColor) * schlickWeight(vh);
  const Spectrum metal = metalFresnel * (p_.metallic * lobe);
  const Spectrum diffuse = p_.baseColor * (baseWeight * (1.0f - p_.transmission) * kInvPi * wi.z);
  return metal + dielectric * (Spectrum(fd * lobe) + diffuse);
}

float PrincipledBsdf::pdfLocal(const Vec3& wo, const Vec3& wi) const {
  if (!(wo.z > 0.0f) || wi.z == 0.0f) return 0.0f;
  const LobeChoice c = lobes(wo.z);
  const bool reflection = wi.z > 0.0f;
  const Vec3 wr = reflection ? wi : mirrored(wi);
  const Vec3 sum = wo + wr;
  const float length = glm::length(sum);
  const float ggx = length > 0.0f ? ggxReflectionPdf(ggx_, wo, sum / length) : 0.0f;
  if (!reflection) return straight_ ? 0.0f : c.transmission * ggx;
  return c.specular * ggx + c.diffuse * cosineHemispherePdf(wi.z);
}

Spectrum PrincipledBsdf::evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  const Frame frame = Frame::fromNormal(n);
  const Spectrum opaque = glassWeight_ < 1.0f ? evalLocal(frame.toLocal(wo), frame.toLocal(wi)) : Spectrum(0.0f);
  if (!glass_) return opaque;
  return glass_->evalCos(n, wo, wi, front) * glassWeight_ + opaque * (1.0f - glassWeight_);
}

float PrincipledBsdf::pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const {
  const Frame frame = Frame::fromNormal(n);
  const float opaque = glassWeight_ < 1.0f ? pdfLocal(frame.toLocal(wo), frame.toLocal(wi)) : 0.0f;
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
  const LobeChoice c = lobes(woLocal.z);
  // A thin wall's smooth transmission first (Bsdf::straightProbability's convention): straight
  // through, weighed by its share of the choice; then diffuse and specular as for any surface.
  float choice = uLobe;
  if (straight_) {
    if (choice < c.transmission)
      return MaterialSample{-wo, straightAt(woLocal.z) / c.transmission, 0.0f, true, 1.0f, /*straight=*/true};
    choice -= c.transmission;
  }
  Vec3 wiLocal;
  if (choice < c.diffuse) {
    wiLocal = sampleCosineHemisphere(u);
  } else {
    const Vec3 wr = reflect(woLocal, ggx_.sampleVisibleNormal(woLocal, u));
    if (!(wr.z > 0.0f)) return std::nullopt;  // reflected below the surface: masked, absorbed
    wiLocal = !straight_ && choice < c.diffuse + c.transmission ? mirrored(wr) : wr;
  }
  const float pdf = pdfLocal(woLocal, wiLocal);
  if (!(pdf > 0.0f)) return std::nullopt;
  const Spectrum f = evalLocal(woLocal, wiLocal);
  if (isBlack(f)) return std::nullopt;
  return MaterialSample{frame.toWorld(wiLocal), f / pdf, pdf, false};
}

Spectrum PrincipledBsdf::straightAt(float cosO) const {
  const float fd = p_.specular * (f0_ + (1.0f - f0_) * schlickWeight(cosO));
  return p_.baseColor * ((1.0f - p_.metallic) * p_.transmission * (1.0f - fd));
}

Spectrum PrincipledBsdf::straightTransmittance(const Vec3& n, const Vec3& wo) const {
  return straight_ ? straightAt(std::abs(glm::dot(n, wo))) : Spectrum(0.0f);
}

float PrincipledBsdf::straightProbability(const Vec3& n, const Vec3& wo) const {
  return straight_ ? lobes(std::abs(glm::dot(n, wo))).transmission : 0.0f;
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
