#pragma once
// Glass and other clear dielectrics (issue 20): a boundary between the outside (index 1) and a
// medium of index `ior` behind the front face.
//
// Smooth: exact Fresnel for unpolarised light (material/fresnel.h), Snell refraction, total
// internal reflection, and refracted radiance scaled by 1/eta^2 (radiance is compressed into the
// smaller solid angle of the denser side: Veach 1997 §5.2; pbrt-v4 DielectricBxDF), so a glass
// object in a uniform field of radiance L shows L. Thin-walled: a pane of negligible thickness
// (windows): the two faces' inter-reflections summed, light passing straight through.
#include <memory>

#include "material/bsdf.h"

namespace lensfarm {

class FieldReader;

class DielectricBsdf final : public Bsdf {
 public:
  // `transmittance`: a tint applied to every reflected and refracted path (1: clear glass).
  DielectricBsdf(const Spectrum& transmittance, float ior, bool thinWalled)
      : tint_(transmittance), ior_(ior), thinWalled_(thinWalled) {}
  BsdfTraits traits() const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;

 private:
  Spectrum tint_;
  float ior_;
  bool thinWalled_;
};

// `dielectric`: transmittance, ior, thin_walled (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseDielectric(FieldReader& r);

}  // namespace lensfarm
