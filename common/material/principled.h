#pragma once
// The glTF 2.0 metallic-roughness material (glTF 2.0 specification, Appendix B, "BRDF
// Implementation"), with the KHR_materials_transmission and KHR_materials_ior extensions, so that a
// glTF material maps onto it field for field:
//
//   material        = mix(dielectric_brdf, metal_brdf, metallic)
//   metal_brdf      = specular_brdf(alpha) * (C + (1 - C)(1 - |V.H|)^5)           (Schlick, F0 = C)
//   dielectric_brdf = mix(base, specular_brdf(alpha), F_d),  F_d = f0 + (1 - f0)(1 - |V.H|)^5,
//                     f0 = ((ior - 1) / (ior + 1))^2
//   base            = mix(C / pi, C * specular_btdf(alpha), transmission)
//
// with C the base colour, alpha = roughness^2 and specular_brdf the GGX microfacet BRDF with
// height-correlated Smith masking (material/microfacet.h). One deliberate difference: the base
// (diffuse and transmission) is weighted by 1 - F_d(N.V), the Fresnel term of the view direction,
// where the specification's fresnel_mix takes 1 - F_d(V.H) per light direction. That form is not
// energy conserving: a smooth white dielectric seen at 85 degrees returns 1.58 times the light it
// receives (tests: Principled.NeverReflectsMoreThanItReceives), because the specular layer takes
// F(85 deg) = 0.44 while the base, seen through half vectors near the normal, still gives ~0.96.
// With 1 - F_d(N.V) the layers share the light the view direction's Fresnel term splits; the
// specular and metal lobes are the specification's exactly (tests: Principled.*). As glTF defines transmission without
// KHR_materials_volume, the surface is thin-walled: transmitted light leaves on the far side
// without bending, blurred by the same GGX lobe mirrored through the surface. Smooth (alpha below
// GgxDistribution::kSmoothAlpha) that lobe is a delta straight through: the surface is a thin
// wall (BsdfTraits::thinWall) whose straight transmittance C (1 - m) t (1 - F_d(N.V)) shadow
// rays carry across it, so a glass pane lit by a point light casts a shadow of its tint.
//
// Not thin-walled (`thin_walled` false; glTF's KHR_materials_volume with thicknessFactor > 0) the
// surface bounds a solid of index `ior`, and its transmitting share is a dielectric boundary
// that refracts (material/dielectric.h: exact Fresnel, total internal reflection inside, Walter
// et al. 2007 when rough), tinted by the base colour. With w = transmission (1 - metallic) the
// model is the mixture
//   w glass(C, ior, roughness) + (1 - w) principled(transmission 0, metallic m / (1 - w))
// which keeps the metal share m and the opaque dielectric share (1 - m)(1 - t) of the thin form;
// one sample picks a component with probability w, and a non-delta sample is weighed by the
// mixture's density. Smooth glass with w = 1 is the dielectric's delta model exactly.
//
// Sampling picks one of three lobes — the GGX reflection (metal and dielectric specular), the
// cosine-weighted diffuse, the mirrored GGX transmission — with probabilities from their
// approximate albedos at wo, and weighs by the mixture's density (one-sample MIS over lobes), so
// every lobe is evaluated for light samples and scattered rays alike. Roughness below
// GgxDistribution::kSmoothAlpha's is rendered at that width (a near-mirror, not a delta lobe).
#include <memory>
#include <optional>

#include "common/material/bsdf.h"
#include "common/material/dielectric.h"
#include "common/material/microfacet.h"
#include "common/material/principled_model.h"

namespace lensfarm {

class FieldReader;

struct PrincipledParams {
  Spectrum baseColor{1.0f};  // glTF baseColorFactor (linear)
  float metallic = 1.0f;     // glTF defaults: a rough metal
  float roughness = 1.0f;
  float transmission = 0.0f;  // KHR_materials_transmission
  float ior = 1.5f;           // KHR_materials_ior
  // KHR_materials_specular's specularFactor: the weight of the dielectric's specular layer
  // (0: a purely diffuse surface, as exporters write for one).
  float specular = 1.0f;
  // KHR_materials_specular's specularColorFactor, as one number (its Rec. 709 luminance): the
  // dielectric's F0 is min(1, F0(ior) x specularColor), untinted (0: only grazing reflection is
  // left, as Blender writes its Specular 0).
  float specularColor = 1.0f;
  // Whether transmission is a thin wall (glTF's default) or the boundary of a refracting solid.
  bool thinWalled = true;
};

class PrincipledBsdf final : public Bsdf {
 public:
  explicit PrincipledBsdf(const PrincipledParams& params);
  BsdfTraits traits() const override;
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;
  Spectrum straightTransmittance(const Vec3& n, const Vec3& wo) const override;
  float straightProbability(const Vec3& n, const Vec3& wo) const override;
  // Only without a solid's refracting share and without a straight transmission.
  bool laneModel(PrincipledModel& model) const override;

 private:
  // The thin-walled model's sample (all of it, or the opaque share of a solid).
  std::optional<MaterialSample> sampleOpaque(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u) const;

  PrincipledParams p_;
  PrincipledModel model_;  // the opaque share's formulas (material/principled_model.h)
  // A solid's refracting share (not thin-walled): glassWeight_ = w of the header, glass_ set.
  float glassWeight_ = 0.0f;
  std::optional<DielectricBsdf> glass_;
  // Thin-walled, transmitting and smooth: the transmission is a delta straight through.
  bool straight() const { return model_.straight != 0.0f; }
  Spectrum straightAt(float cosO) const;  // C (1 - m) t (1 - F_d(cos_o))
};

// `principled`: base_color, metallic, roughness, transmission, ior, specular (docs/scene-format.md).
std::shared_ptr<const Bsdf> parsePrincipled(FieldReader& r);

}  // namespace lensfarm
