#pragma once
// `interface`: a surface that does not scatter light, only bounds a medium (pbrt-v4's
// "interface" material): an index-matched boundary. Rays, shadow rays included, pass straight
// through it; crossing it moves a path into or out of the medium of its material's
// `interior_medium` (render/volume_integrator.h, docs/media.md). Without a medium in the scene
// it would be invisible, which the scene loader refuses as a likely mistake.
#include <memory>

#include "common/material/bsdf.h"

namespace lensfarm {

class FieldReader;

class InterfaceBsdf final : public Bsdf {
 public:
  BsdfTraits traits() const override;
  std::optional<MaterialSample> sample(const Vec3&, const Vec3&, float, Vec2, bool) const override {
    return std::nullopt;
  }
};

std::shared_ptr<const Bsdf> parseInterface(FieldReader& r);

}  // namespace lensfarm
