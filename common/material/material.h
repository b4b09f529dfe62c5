#pragma once
// Surface materials (seed §4.2, §4.5.1): a scattering model (material/bsdf.h, whose header holds
// the conventions) and emission.
//
// All materials shade both sides of a surface. Emission is one-sided (front face, the face whose
// normal is cross(v1 - v0, v2 - v0)) unless `twoSidedEmission` is set.
//
// Material types are registered in one place, kMaterialTypes in material.cpp: a new type adds its
// own header/source pair (its Bsdf and its parse function) and one line there.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "material/bsdf.h"
#include "material/lambertian.h"

namespace lensfarm {

class FieldReader;

class Material {
 public:
  Material() = default;
  // `bsdf` null: reflects nothing (a pure emitter).
  Material(std::string name, std::shared_ptr<const Bsdf> bsdf, const Spectrum& emission = Spectrum(0.0f),
           bool twoSidedEmission = false);

  std::string name;
  Spectrum emission{0.0f};  // emitted radiance
  bool twoSidedEmission = false;

  const Bsdf* bsdf() const { return bsdf_.get(); }
  const BsdfTraits& traits() const { return traits_; }
  bool isEmissive() const { return !isBlack(emission); }
  bool reflects() const { return traits_.reflects; }
  // Every lobe is a delta (mirrors, smooth glass and metal): no light sampling.
  bool isSpecular() const { return traits_.delta; }
  bool isLambertian() const { return traits_.lambertian; }
  bool choosesLobe() const { return traits_.choosesLobe; }
  // The Lambertian albedo (black for any other model).
  const Spectrum& albedo() const { return traits_.albedo; }

  // The Bsdf's, or zero / nothing for a material that reflects nothing (material/bsdf.h).
  Spectrum evalCos(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front = true) const {
    return traits_.reflects ? bsdf_->evalCos(n, wo, wi, front) : Spectrum(0.0f);
  }
  float pdf(const Vec3& n, const Vec3& wo, const Vec3& wi, bool front = true) const {
    return traits_.reflects ? bsdf_->pdf(n, wo, wi, front) : 0.0f;
  }
  std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u, bool front = true) const {
    if (!traits_.reflects) return std::nullopt;
    return bsdf_->sample(n, wo, uLobe, u, front);
  }
  // sample() for a scene whose materials are all Lambertian: without the virtual call.
  std::optional<MaterialSample> sampleLambertian(const Vec3& n, Vec2 u) const {
    if (!traits_.lambertian || !traits_.reflects) return std::nullopt;
    return lensfarm::sampleLambertian(traits_.albedo, n, u);
  }

 private:
  std::shared_ptr<const Bsdf> bsdf_;
  BsdfTraits traits_;
};

// Reads one entry of the scene's `materials` (docs/scene-format.md, "Materials"): its `type`, the
// type's fields, and `emission` / `two_sided`. Errors name the field (InputError).
Material parseMaterial(const std::string& name, FieldReader& r);
// The names of the registered types, in registration order.
std::vector<std::string> materialTypeNames();

}  // namespace lensfarm
