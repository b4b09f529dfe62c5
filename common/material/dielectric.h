#pragma once
// Glass and other clear dielectrics: a boundary between the outside (index 1) and a
// medium of index `ior` behind the front face.
//
// Smooth: exact Fresnel for unpolarised light (material/fresnel.h), Snell refraction, total
// internal reflection, and refracted radiance scaled by 1/eta^2 (radiance is compressed into the
// smaller solid angle of the denser side: Veach 1997 §5.2; pbrt-v4 DielectricBxDF), so a glass
// object in a uniform field of radiance L shows L. Thin-walled: a pane of negligible thickness
// (windows): the two faces' inter-reflections summed, light passing straight through.
//
// Rough (frosted glass): Walter et al. 2007's GGX microfacet BSDF. A visible microfacet normal m
// is sampled (Heitz 2018); the path reflects off it with probability F(wo.m) and refracts through
// it otherwise. With eta = n_wi / n_wo (the side wi lies in over wo's):
//   reflection    f cos_i = F D(h) G / (4 cos_o),                           h = normalize(wo + wi)
//   transmission  f cos_i = (1 - F) D(m) G |wi.m| |wo.m| / (cos_o (wi.m + wo.m / eta)^2) / eta^2,
//                 m = normalize(eta wi + wo) turned to wo's side         [W07 eqs. 16, 21; pbrt-v4]
// with the same 1/eta^2 radiance scaling as the smooth case, and pdfs D_wo(m) |Jacobian| times
// the branch probability. Reciprocity holds in its generalised form f(wo, wi) eta^2 = f(wi, wo)
// (tests: RoughDielectric.*). Below GgxDistribution::kSmoothAlpha the surface is the smooth one.
#include <memory>

#include "common/material/bsdf.h"
#include "common/material/microfacet.h"

namespace lensfarm {

class FieldReader;

class DielectricBsdf final : public Bsdf {
 public:
  // `transmittance`: a tint applied to every reflected and refracted path (1: clear glass).
  // `roughness`: perceptual, alpha = roughness^2; a thin-walled pane is smooth (roughness 0).
  DielectricBsdf(const Spectrum& transmittance, float ior, bool thinWalled, float roughness = 0.0f);
  BsdfTraits traits() const override;
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;
  // A thin-walled pane: tint (1 - R'), R' = 2R / (1 + R) its reflectance at wo's angle.
  Spectrum straightTransmittance(const Vec3& n, const Vec3& wo) const override;
  float straightProbability(const Vec3& n, const Vec3& wo) const override;
  bool smooth() const { return smooth_; }

 private:
  // The rough BSDF in the local frame (z = n, wo.z > 0), eta = n_transmitted / n_incident: f cos
  // and pdf together.
  void evalLocal(const Vec3& wo, const Vec3& wi, float eta, Spectrum* f, float* pdf) const;

  Spectrum tint_;
  float ior_;
  bool thinWalled_;
  GgxDistribution ggx_;
  bool smooth_;
};

// `dielectric`: transmittance, ior, thin_walled (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseDielectric(FieldReader& r);

}  // namespace lensfarm
