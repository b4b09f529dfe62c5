#pragma once
// Metals: reflection weighted by a conductor's Fresnel term per RGB channel, times a
// tint; smooth (a delta lobe) or rough (GGX microfacets).
//
// Fresnel: the exact term of a complex index eta + i k (material/fresnel.h; at normal incidence
// F0 = ((eta-1)^2 + k^2) / ((eta+1)^2 + k^2), towards grazing 1), or, in glTF's metallic
// parameterisation, Schlick's F0 + (1 - F0)(1 - cos)^5 with the base colour as F0.
//
// Rough: the GGX microfacet BRDF f = F(wo.h) D(h) G(wo, wi) / (4 cos_o cos_i) (Walter et al.
// 2007) with height-correlated Smith masking (Heitz 2014), sampled by visible normals (Heitz
// 2018), plus, unless turned off, Kulla & Conty's (2017) multiple-scattering lobe, so that a rough
// metal keeps the energy the single-scattering model loses between its microfacets (59 % at
// roughness 1 with F = 1; material/ggx_albedo.h). The two lobes are sampled as a mixture, the
// compensation lobe (cosine-weighted) with the probability 1 - E(mu_o) of the energy it carries.
// Below GgxDistribution::kSmoothAlpha the surface is the smooth one.
#include <memory>
#include <string>

#include "common/material/bsdf.h"
#include "common/material/microfacet.h"

namespace lensfarm {

class FieldReader;
class GgxAlbedoTable;

// A conductor's Fresnel reflectance per channel.
struct ConductorFresnel {
  bool schlick = false;
  Spectrum eta{1.0f}, k{0.0f};  // the complex index (exact form)
  Spectrum f0{1.0f};            // reflectance at normal incidence (Schlick's form)

  Spectrum operator()(float cosI) const;
  // F_avg = 2 integral_0^1 F(mu) mu dmu, the cosine-weighted hemispherical average (Kulla-Conty).
  Spectrum average() const;
  static ConductorFresnel complex(const Spectrum& eta, const Spectrum& k);
  static ConductorFresnel fromF0(const Spectrum& f0);
};

class ConductorBsdf final : public Bsdf {
 public:
  // `roughness`: perceptual, alpha = roughness^2 (glTF, Burley 2012); 0 = polished.
  ConductorBsdf(const ConductorFresnel& fresnel, const Spectrum& tint, float roughness = 0.0f,
                bool energyCompensation = true);
  // The exact Fresnel of eta + i k, polished.
  ConductorBsdf(const Spectrum& eta, const Spectrum& k, const Spectrum& tint)
      : ConductorBsdf(ConductorFresnel::complex(eta, k), tint) {}

  BsdfTraits traits() const override;
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;
  // The Fresnel reflectance per channel at cosine cosI (times nothing: no tint).
  Spectrum fresnel(float cosI) const { return fresnel_(cosI); }
  bool smooth() const { return smooth_; }

 private:
  // In the local frame (z = n): f cos and pdf of the rough lobes.
  Spectrum evalLocal(const Vec3& wo, const Vec3& wi) const;
  float pdfLocal(const Vec3& wo, const Vec3& wi) const;
  float compensationProbability(float muO) const;

  ConductorFresnel fresnel_;
  Spectrum tint_;
  GgxDistribution ggx_;
  bool smooth_;
  const GgxAlbedoTable* albedo_ = nullptr;  // with energy compensation
  Spectrum msFresnel_{0.0f};                // kullaContyFresnel(F_avg, E_avg) * tint
  float eAvg_ = 1.0f;
};

// Optical constants of a named metal (Au, Ag, Cu, Al) at about 650, 550 and 450 nm; false for an
// unknown name.
bool namedMetal(const std::string& name, Spectrum& eta, Spectrum& k);

// `conductor`: metal, eta and k, or reflectance; tint, roughness, energy_compensation
// (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseConductor(FieldReader& r);

}  // namespace lensfarm
