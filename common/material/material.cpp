#include "common/material/material.h"

#include <algorithm>

#include "common/material/conductor.h"
#include "common/material/dielectric.h"
#include "common/material/interface.h"
#include "common/material/lambertian.h"
#include "common/material/mirror.h"
#include "common/material/principled.h"
#include "common/material/subsurface.h"
#include "common/util/field_reader.h"

namespace lensfarm {

namespace {
// A material type: its name in the scene file and the parser of its fields (null: no Bsdf).
struct MaterialType {
  const char* name;
  std::shared_ptr<const Bsdf> (*parse)(FieldReader&);
  const char* emissionField;  // the field its emitted radiance is read from ("" where it has none)
};

// The one registration point of material types.
constexpr MaterialType kMaterialTypes[] = {
    {"lambertian", parseLambertian, "emission"}, {"mirror", parseMirror, ""},
    {"rippled_mirror", parseRippledMirror, ""},  {"dielectric", parseDielectric, ""},
    {"conductor", parseConductor, ""},           {"principled", parsePrincipled, "emission"},
    {"subsurface", parseSubsurface, ""},         {"interface", parseInterface, ""},
    {"emissive", nullptr, "radiance"},
};
}  // namespace

Material::Material(std::string materialName, std::shared_ptr<const Bsdf> bsdf, const Spectrum& emitted, bool twoSided)
    : name(std::move(materialName)), emission(emitted), twoSidedEmission(twoSided), bsdf_(std::move(bsdf)) {
  if (bsdf_) {
    traits_ = bsdf_->traits();
    interior = bsdf_->interiorMedium();
  }
}

Material Material::textured(std::string name, std::shared_ptr<const MaterialTextures> textures,
                            const Spectrum& emission, bool twoSidedEmission) {
  Material m(std::move(name), std::make_shared<PrincipledBsdf>(textures->factors), emission, twoSidedEmission);
  m.textures_ = std::move(textures);
  return m;
}

PrincipledParams Material::principledAt(const Vec2 (&uv)[2], float width) const {
  const MaterialTextures& t = *textures_;
  PrincipledParams p = t.factors;
  if (t.baseColor) p.baseColor *= Spectrum(t.baseColor.sample(uv, width));
  if (t.metallicRoughness) {
    // glTF 2.0 §3.9.2: metalness in B, roughness in G.
    const Vec4 mr = t.metallicRoughness.sample(uv, width);
    p.roughness = std::clamp(p.roughness * mr.g, 0.0f, 1.0f);
    p.metallic = std::clamp(p.metallic * mr.b, 0.0f, 1.0f);
  }
  p.baseColor = glm::clamp(p.baseColor, Spectrum(0.0f), Spectrum(1.0f));
  return p;
}

Spectrum Material::emissionAt(const Vec2 (&uv)[2], float width) const {
  if (!textures_ || !textures_->emissive) return emission;
  return emission * glm::max(Spectrum(textures_->emissive.sample(uv, width)), Spectrum(0.0f));
}

float Material::alphaAt(const Vec2 (&uv)[2]) const {
  if (!textures_) return 1.0f;
  const float a = textures_->baseColor ? textures_->baseColor.sample(uv, 0.0f).a : 1.0f;
  return textures_->alphaFactor * a;
}

std::vector<std::string> materialTypeNames() {
  std::vector<std::string> names;
  for (const MaterialType& t : kMaterialTypes) names.emplace_back(t.name);
  return names;
}

Material parseMaterial(const std::string& name, FieldReader& r, const MediumTable& media) {
  const std::string type = r.string("type");
  const MaterialType* found = nullptr;
  for (const MaterialType& t : kMaterialTypes)
    if (type == t.name) found = &t;
  if (!found) {
    std::string expected;
    for (const MaterialType& t : kMaterialTypes) expected += std::string(expected.empty() ? "" : ", ") + t.name;
    r.fail(r.field("type"), "unknown material type \"" + type + "\" (expected " + expected + ")");
  }
  std::shared_ptr<const Bsdf> bsdf = found->parse ? found->parse(r) : nullptr;
  Spectrum emission(0.0f);
  const std::string emissionField = found->emissionField;
  if (emissionField == "radiance")
    emission = r.color("radiance", kRadianceRange);
  else if (!emissionField.empty())
    emission = r.color(emissionField, Spectrum(0.0f), kRadianceRange);
  if (!emissionField.empty() && r.has("emission_strength")) {
    // glTF's KHR_materials_emissive_strength: the emission colour times a factor.
    const double strength = r.number("emission_strength", 0.0, kRadianceRange.hi);
    for (int c = 0; c < 3; ++c) {
      const double e = double(emission[c]) * strength;
      if (e != 0.0 && (e < kRadianceRange.lo || e > kRadianceRange.hi))
        r.fail(r.field("emission_strength"),
               "makes the emitted radiance " + std::to_string(e) + ", outside [1e-30, 1e30] (see the colour ranges)");
      emission[c] = float(e);
    }
  }
  Material m(name, std::move(bsdf), emission);
  if (m.isEmissive() || r.has("two_sided")) m.twoSidedEmission = r.boolean("two_sided", false);
  const auto medium = [&](const char* key) {
    const std::string mediumName = r.string(key);
    const auto it = media.find(mediumName);
    if (it == media.end()) r.fail(r.field(key), "unknown medium \"" + mediumName + "\" (not in media)");
    return it->second;
  };
  if (r.has("interior_medium")) {
    if (m.interior)
      r.fail(r.field("interior_medium"), "a subsurface material makes its own medium from albedo and mean_free_path");
    m.interior = medium("interior_medium");
  } else if (m.passesThrough()) {
    r.fail(r.field("interior_medium"), "is required: an interface only bounds a medium (without one it is invisible)");
  }
  if (r.has("exterior_medium")) m.exterior = medium("exterior_medium");
  r.finish();
  return m;
}

}  // namespace lensfarm
