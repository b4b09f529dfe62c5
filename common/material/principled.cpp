#include "material/principled.h"

#include <algorithm>
#include <cmath>

#include "math/sampling.h"
#include "scene/field_reader.h"

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
  f0_ = r * r;
}

BsdfTraits PrincipledBsdf::traits() const {
  // Black only when nothing can scatter: a black metal (F0 = 0 still reflects at grazing, but
  // C = 0 with metallic 1 reflects (1 - 0) x^5: not black). Every glTF material scatters something.
  const bool transmits = p_.transmission > 0.0f && p_.metallic < 1.0f;
  BsdfTraits t = BsdfTraits::glossyLobes(true, transmits ? "principled (glTF) with transmission" : "principled (glTF)");
  t.transmits = transmits;
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
  const float baseWeight = 1.0f - p_.specular * (f0_ + (1.0f - f0_) * schlickWeight(wo.z));  // see the header: 1 - F_d(N.V)
  const float dielectric = 1.0f - p_.metallic;
  if (!reflection) return p_.baseColor * (dielectric * p_.transmission * baseWeight * lobe);
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
  if (!reflection) return c.transmission * ggx;
  return c.specular * ggx + c.diffuse * cosineHemispherePdf(wi.z);
}

Spectrum PrincipledBsdf::evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool /*front*/) const {
  const Frame frame = Frame::fromNormal(n);
  return evalLocal(frame.toLocal(wo), frame.toLocal(wi));
}

float PrincipledBsdf::pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool /*front*/) const {
  const Frame frame = Frame::fromNormal(n);
  return pdfLocal(frame.toLocal(wo), frame.toLocal(wi));
}

std::optional<MaterialSample> PrincipledBsdf::sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u,
                                                     bool /*front*/) const {
  const Frame frame = Frame::fromNormal(n);
  const Vec3 woLocal = frame.toLocal(wo);
  if (!(woLocal.z > 0.0f)) return std::nullopt;
  const LobeChoice c = lobes(woLocal.z);
  Vec3 wiLocal;
  if (uLobe < c.diffuse) {
    wiLocal = sampleCosineHemisphere(u);
  } else {
    const Vec3 wr = reflect(woLocal, ggx_.sampleVisibleNormal(woLocal, u));
    if (!(wr.z > 0.0f)) return std::nullopt;  // reflected below the surface: masked, absorbed
    wiLocal = uLobe < c.diffuse + c.transmission ? mirrored(wr) : wr;
  }
  const float pdf = pdfLocal(woLocal, wiLocal);
  if (!(pdf > 0.0f)) return std::nullopt;
  const Spectrum f = evalLocal(woLocal, wiLocal);
  if (isBlack(f)) return std::nullopt;
  return MaterialSample{frame.toWorld(wiLocal), f / pdf, pdf, false};
}

std::shared_ptr<const Bsdf> parsePrincipled(FieldReader& r) {
  PrincipledParams p;
  p.baseColor = r.color("base_color", Spectrum(1.0f), kReflectanceRange);
  p.metallic = float(r.number("metallic", 1.0, 0.0, 1.0));
  p.roughness = float(r.number("roughness", 1.0, 0.0, 1.0));
  p.transmission = float(r.number("transmission", 0.0, 0.0, 1.0));
  p.ior = float(r.number("ior", 1.5, 1.0, 10.0));
  p.specular = float(r.number("specular", 1.0, 0.0, 1.0));
  return std::make_shared<PrincipledBsdf>(p);
}

}  // namespace lensfarm
