#pragma once
// Surface materials (2013 report §4.2, §4.5.1): a scattering model (material/bsdf.h, whose header holds
// the conventions) and emission.
//
// All materials shade both sides of a surface. Emission is one-sided (front face, the face whose
// normal is cross(v1 - v0, v2 - v0)) unless `twoSidedEmission` is set.
//
// Material types are registered in one place, kMaterialTypes in material.cpp: a new type adds its
// own header/source pair (its Bsdf and its parse function) and one line there.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/material/bsdf.h"
#include "common/material/lambertian.h"
#include "common/material/principled.h"
#include "common/texture/texture.h"

namespace lensfarm {

class FieldReader;

// glTF alphaMode: kMask cuts the surface out where alpha < alphaCutoff (render/ray_caster.h skips
// those hits); kBlend is rendered as kMask with cutoff 0.5 (a warning says so); kOpaque ignores
// alpha.
enum class AlphaMode { kOpaque, kMask, kBlend };

// The inputs of a material whose parameters vary over the surface: the glTF metallic-roughness
// model (material/principled.h) with its textures, as glTF defines them (glTF 2.0 §3.9): each
// texture multiplies its factor. MTL maps (map_Kd, map_bump, ...) land in the same slots.
// Occlusion textures are not read: a path tracer computes occlusion (docs/scene-format.md).
struct MaterialTextures {
  PrincipledParams factors;      // baseColorFactor (RGB), metallicFactor, roughnessFactor, ...
  float alphaFactor = 1.0f;      // baseColorFactor's alpha
  TextureRef baseColor;          // RGB: base colour (decoded from sRGB), A: alpha
  TextureRef metallicRoughness;  // B: metallic, G: roughness (linear)
  TextureRef normal;             // tangent-space normal map: RGB = (n + 1) / 2, +y along the v tangent
  float normalScale = 1.0f;      // scales the map's x and y (glTF normalTexture.scale)
  TextureRef emissive;           // RGB multiplies the material's emission (decoded from sRGB)
  AlphaMode alphaMode = AlphaMode::kOpaque;
  float alphaCutoff = 0.5f;

  // Whether anything varies over the surface (false: the factors alone describe the material).
  bool varies() const { return baseColor || metallicRoughness || normal || emissive; }
  bool cutsOut() const { return alphaMode != AlphaMode::kOpaque; }
};

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
  // The medium behind the front face (docs/media.md): a path that crosses the surface against its
  // normal enters it, one that crosses along the normal leaves it for `exterior`, or the scene's
  // medium where that is null (pbrt's MediumInterface). Both null: crossing the surface does not
  // change the medium a path is in.
  std::shared_ptr<const Medium> interior, exterior;
  // A medium's index-matched boundary (material/interface.h): rays cross it unchanged.
  bool passesThrough() const { return traits_.passesThrough; }
  // A thin wall that lets light straight through with a tint (BsdfTraits::thinWall).
  bool isThinWall() const { return traits_.thinWall; }
  Spectrum straightTransmittance(const Vec3& n, const Vec3& wo) const {
    return traits_.thinWall ? bsdf_->straightTransmittance(n, wo) : Spectrum(0.0f);
  }
  float straightProbability(const Vec3& n, const Vec3& wo) const {
    return traits_.thinWall ? bsdf_->straightProbability(n, wo) : 0.0f;
  }

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

  // The record the packet tracer's lane loops shade the material with, where they can (Bsdf::laneModel).
  bool laneModel(PrincipledModel& model) const { return traits_.reflects && bsdf_->laneModel(model); }

  // A material with textures (glTF, MTL): its Bsdf at a point is the principled model with the
  // textures' values there (principledAt). `emission` is the emissive factor; the emissive
  // texture multiplies it.
  static Material textured(std::string name, std::shared_ptr<const MaterialTextures> textures,
                           const Spectrum& emission = Spectrum(0.0f), bool twoSidedEmission = false);
  const MaterialTextures* textures() const { return textures_.get(); }
  // Whether the material's scattering or emission varies over the surface.
  bool varies() const { return textures_ && textures_->varies(); }
  // The principled parameters at a point with texture coordinates uv (both sets), for a footprint
  // of `width` in texture space (texture/texture.h). Only for materials with textures.
  PrincipledParams principledAt(const Vec2 (&uv)[2], float width) const;
  // The emitted radiance at such a point (the emissive texture times the emission).
  Spectrum emissionAt(const Vec2 (&uv)[2], float width) const;
  // Alpha at a point (base colour texture's A times alphaFactor; 1 without textures).
  float alphaAt(const Vec2 (&uv)[2]) const;

 private:
  std::shared_ptr<const Bsdf> bsdf_;
  BsdfTraits traits_;
  std::shared_ptr<const MaterialTextures> textures_;
};

// The scene's named media (docs/scene-format.md, "Media"), for a material's `interior_medium`.
using MediumTable = std::map<std::string, std::shared_ptr<const Medium>>;

// Reads one entry of the scene's `materials` (docs/scene-format.md, "Materials"): its `type`, the
// type's fields, `emission` / `two_sided`, `interior_medium` and `exterior_medium` (names in
// `media`). Errors name
// the field (InputError).
Material parseMaterial(const std::string& name, FieldReader& r, const MediumTable& media = {});
// The names of the registered types, in registration order.
std::vector<std::string> materialTypeNames();

}  // namespace lensfarm
