#pragma once
// Metals (issue 20): reflection weighted by the conductor Fresnel term of a complex index
// eta + i k per RGB channel (material/fresnel.h), times a tint.
//
// Smooth: the mirror direction only. At normal incidence F0 = ((eta-1)^2 + k^2) / ((eta+1)^2 + k^2);
// grazing light reflects fully.
#include <memory>

#include "material/bsdf.h"

namespace lensfarm {

class FieldReader;

class ConductorBsdf final : public Bsdf {
 public:
  ConductorBsdf(const Spectrum& eta, const Spectrum& k, const Spectrum& tint) : eta_(eta), k_(k), tint_(tint) {}
  BsdfTraits traits() const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;
  // The Fresnel reflectance per channel at cosine cosI.
  Spectrum fresnel(float cosI) const;

 private:
  Spectrum eta_, k_, tint_;
};

// Optical constants of a named metal (Au, Ag, Cu, Al) at about 650, 550 and 450 nm; false for an
// unknown name.
bool namedMetal(const std::string& name, Spectrum& eta, Spectrum& k);

// `conductor`: metal or eta and k, tint (docs/scene-format.md, "Materials").
std::shared_ptr<const Bsdf> parseConductor(FieldReader& r);

}  // namespace lensfarm
