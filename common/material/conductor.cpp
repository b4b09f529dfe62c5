#include "common/material/conductor.h"

#include <algorithm>
#include <string>

#include "common/material/fresnel.h"
#include "common/material/ggx_albedo.h"
#include "common/math/sampling.h"
#include "common/util/field_reader.h"

namespace lensfarm {

namespace {
// A conductor's complex index eta + i k per channel: real metals have eta from about 0.05 (silver)
// to a few, and k up to about 10 (aluminium in the blue is 4.8, in the infrared more).
constexpr ColorRange kConductorEtaRange{0.01, 10.0, "an index below 0.01 is not a metal in the visible",
                                        "an index above 10 is not a material in the visible"};
constexpr ColorRange kConductorKRange{1e-6, 100.0, "an extinction coefficient below 1e-6 is a dielectric: write 0",
                                      "an extinction coefficient above 100 is not a material in the visible"};

// Named metals for `conductor.metal`: eta and k at about 650, 550 and 450 nm (the red, green and
// blue primaries), from measured optical constants (Au, Ag, Cu: Johnson & Christy 1972; Al:
// Rakic 1995; as tabulated by refractiveindex.info).
struct NamedMetal {
  const char* name;
  Spectrum eta, k;
};
constexpr NamedMetal kNamedMetals[] = {
    {"Au", {0.143f, 0.374f, 1.442f}, {3.983f, 2.385f, 1.603f}},
    {"Ag", {0.155f, 0.117f, 0.138f}, {4.828f, 3.122f, 2.147f}},
    {"Cu", {0.200f, 0.924f, 1.102f}, {3.912f, 2.452f, 2.142f}},
    {"Al", {1.657f, 0.880f, 0.521f}, {9.224f, 6.270f, 4.837f}},
};
}  // namespace

bool namedMetal(const std::string& name, Spectrum& eta, Spectrum& k) {
  for (const NamedMetal& m : kNamedMetals)
    if (name == m.name) {
      eta = m.eta, k = m.k;
      return true;
    }
  return false;
}

Spectrum ConductorFresnel::operator()(float cosI) const {
  if (schlick) {
    const float c = std::min(1.0f, std::abs(cosI));
    const float m = 1.0f - c, m2 = m * m;
    return f0 + (Spectrum(1.0f) - f0) * (m2 * m2 * m);
  }
  return Spectrum(fresnelConductor(cosI, eta.r, k.r), fresnelConductor(cosI, eta.g, k.g),
                  fresnelConductor(cosI, eta.b, k.b));
}

Spectrum ConductorFresnel::average() const {
  if (schlick) return (Spectrum(1.0f) + 20.0f * f0) / 21.0f;  // 2 integral of Schlick's F mu dmu, exactly
  // Gauss-Legendre would do; F is smooth in mu, so the midpoint rule on 256 cells is within 1e-5.
  constexpr int kCells = 256;
  DVec3 sum(0.0);
  for (int i = 0; i < kCells; ++i) {
    const float mu = (float(i) + 0.5f) / float(kCells);
    sum += DVec3((*this)(mu)) * double(mu);
  }
  return Spectrum(sum * (2.0 / kCells));
}

ConductorFresnel ConductorFresnel::complex(const Spectrum& eta, const Spectrum& k) {
  ConductorFresnel f;
  f.eta = eta, f.k = k;
  return f;
}

ConductorFresnel ConductorFresnel::fromF0(const Spectrum& f0) {
  ConductorFresnel f;
  f.schlick = true;
  f.f0 = f0;
  return f;
}

ConductorBsdf::ConductorBsdf(const ConductorFresnel& fresnel, const Spectrum& tint, float roughness,
                             bool energyCompensation)
    : fresnel_(fresnel), tint_(tint), ggx_{GgxDistribution::alphaFromRoughness(roughness)} {
  smooth_ = roughness <= 0.0f || ggx_.isEffectivelySmooth();
  if (!smooth_ && energyCompensation) {
    albedo_ = &GgxAlbedoTable::instance();  // built on first use: scenes without rough metal never pay for it
    eAvg_ = albedo_->Eavg(ggx_.alpha);
    msFresnel_ = kullaContyFresnel(fresnel_.average(), eAvg_) * tint_;
  }
}

BsdfTraits ConductorBsdf::traits() const {
  if (smooth_) return BsdfTraits::deltaLobes(tint_, "metal");
  return BsdfTraits::glossyLobes(!isBlack(tint_), albedo_ ? "rough metal with energy compensation" : "rough metal");
}

float ConductorBsdf::compensationProbability(float muO) const {
  return albedo_ ? std::clamp(1.0f - albedo_->E(muO, ggx_.alpha), 0.0f, 1.0f) : 0.0f;
}

Spectrum ConductorBsdf::evalLocal(const Vec3& wo, const Vec3& wi) const {
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return Spectrum(0.0f);
  Spectrum f(0.0f);
  const Vec3 sum = wo + wi;
  const float length = glm::length(sum);
  if (length > 0.0f) {
    const Vec3 h = sum / length;
    f = tint_ * fresnel_(glm::dot(wo, h)) * ggxReflectionCos(ggx_, wo, wi, h);
  }
  if (albedo_) f += msFresnel_ * (albedo_->multipleScatteringF1(wo.z, wi.z, ggx_.alpha) * wi.z);
  return f;
}

float ConductorBsdf::pdfLocal(const Vec3& wo, const Vec3& wi) const {
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return 0.0f;
  const Vec3 sum = wo + wi;
  const float length = glm::length(sum);
  const float pMs = compensationProbability(wo.z);
  const float specular = length > 0.0f ? ggxReflectionPdf(ggx_, wo, sum / length) : 0.0f;
  return (1.0f - pMs) * specular + pMs * cosineHemispherePdf(wi.z);
}

Spectrum ConductorBsdf::evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool /*front*/) const {
  if (smooth_) return Spectrum(0.0f);
  const Frame frame = Frame::fromNormal(n);
  return evalLocal(frame.toLocal(wo), frame.toLocal(wi));
}

float ConductorBsdf::pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool /*front*/) const {
  if (smooth_) return 0.0f;
  const Frame frame = Frame::fromNormal(n);
  return pdfLocal(frame.toLocal(wo), frame.toLocal(wi));
}

std::optional<MaterialSample> ConductorBsdf::sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u,
                                                    bool /*front*/) const {
  if (smooth_) return MaterialSample{reflect(wo, n), tint_ * fresnel_(glm::dot(n, wo)), 0.0f, true};
  const Frame frame = Frame::fromNormal(n);
  const Vec3 woLocal = frame.toLocal(wo);
  if (!(woLocal.z > 0.0f)) return std::nullopt;
  Vec3 wiLocal;
  if (uLobe < compensationProbability(woLocal.z)) {
    wiLocal = sampleCosineHemisphere(u);
  } else {
    const Vec3 h = ggx_.sampleVisibleNormal(woLocal, u);
    wiLocal = reflect(woLocal, h);
  }
  if (!(wiLocal.z > 0.0f)) return std::nullopt;  // reflected below the surface: masked, absorbed
  const float pdf = pdfLocal(woLocal, wiLocal);
  if (!(pdf > 0.0f)) return std::nullopt;
  const Spectrum f = evalLocal(woLocal, wiLocal);
  return MaterialSample{frame.toWorld(wiLocal), f / pdf, pdf, false};
}

std::shared_ptr<const Bsdf> parseConductor(FieldReader& r) {
  const Spectrum tint = r.color("tint", Spectrum(1.0f), kReflectanceRange);
  const int given = int(r.has("metal")) + int(r.has("eta") || r.has("k")) + int(r.has("reflectance"));
  if (given != 1)
    r.fail(r.field("metal"),
           "give exactly one of metal (Au, Ag, Cu or Al), eta and k, or reflectance (F0, glTF style)");
  ConductorFresnel fresnel;
  if (r.has("metal")) {
    const std::string metal = r.string("metal");
    Spectrum eta, k;
    if (!namedMetal(metal, eta, k))
      r.fail(r.field("metal"), "unknown metal \"" + metal + "\" (expected Au, Ag, Cu or Al)");
    fresnel = ConductorFresnel::complex(eta, k);
  } else if (r.has("reflectance")) {
    fresnel = ConductorFresnel::fromF0(r.color("reflectance", kReflectanceRange));
  } else {
    const Spectrum eta = r.color("eta", kConductorEtaRange);
    for (int c = 0; c < 3; ++c)
      if (eta[c] == 0.0f) r.fail(r.field("eta"), "must be > 0 in every channel");
    fresnel = ConductorFresnel::complex(eta, r.color("k", kConductorKRange));
  }
  const float roughness = float(r.number("roughness", 0.0, 0.0, 1.0));
  const bool compensate = r.boolean("energy_compensation", true);
  return std::make_shared<ConductorBsdf>(fresnel, tint, roughness, compensate);
}

}  // namespace lensfarm
