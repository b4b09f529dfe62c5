#pragma once
// `subsurface`: random-walk subsurface scattering (the way Cycles' and pbrt-v4's random-walk SSS
// work; Chiang, Kutz & Burley 2016). The surface is a diffuse transmitter: light crosses it into
// the mesh cosine-weighted and leaves it the same way (f = 1 / pi on the far side of the surface,
// nothing on the near side), and inside the mesh it walks through a homogeneous medium whose
// coefficients come from the artist's parameters:
//  - albedo A (per channel, in [0, 1]): the reflectance a thick slab shows under diffuse light;
//  - mean_free_path d (per channel, scene units > 0): how far light travels inside;
//  - g: the medium's Henyey-Greenstein anisotropy (0 by default).
// sigma_s and sigma_a follow from A and d by Chiang et al.'s inversion (sssCoefficients,
// medium/homogeneous_medium.h; its accuracy is measured in docs/media.md). The walk is the volume
// path tracer's (render/volume_integrator.h): every scattering event inside counts as a bounce,
// and a walk that reaches the surface from inside leaves through the diffuse transmitter.
// The mesh must be closed and its triangles must face outward (the medium is entered through
// front faces).
#include <memory>

#include "common/material/bsdf.h"

namespace lensfarm {

class FieldReader;
class Medium;

class DiffuseTransmissionBsdf final : public Bsdf {
 public:
  explicit DiffuseTransmissionBsdf(std::shared_ptr<const Medium> interior) : interior_(std::move(interior)) {}
  BsdfTraits traits() const override;
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front) const override;
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front) const override;
  std::shared_ptr<const Medium> interiorMedium() const override { return interior_; }

 private:
  std::shared_ptr<const Medium> interior_;
};

std::shared_ptr<const Bsdf> parseSubsurface(FieldReader& r);

}  // namespace lensfarm
