#include "material/material.h"

#include "material/conductor.h"
#include "material/dielectric.h"
#include "material/lambertian.h"
#include "material/mirror.h"
#include "material/principled.h"
#include "scene/field_reader.h"

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
    {"lambertian", parseLambertian, "emission"},
    {"mirror", parseMirror, ""},
    {"rippled_mirror", parseRippledMirror, ""},
    {"dielectric", parseDielectric, ""},
    {"conductor", parseConductor, ""},
    {"principled", parsePrincipled, "emission"},
    {"emissive", nullptr, "radiance"},
};
}  // namespace

Material::Material(std::string materialName, std::shared_ptr<const Bsdf> bsdf, const Spectrum& emitted,
                   bool twoSided)
    : name(std::move(materialName)), emission(emitted), twoSidedEmission(twoSided), bsdf_(std::move(bsdf)) {
  if (bsdf_) traits_ = bsdf_->traits();
}

std::vector<std::string> materialTypeNames() {
  std::vector<std::string> names;
  for (const MaterialType& t : kMaterialTypes) names.emplace_back(t.name);
  return names;
}

Material parseMaterial(const std::string& name, FieldReader& r) {
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
        r.fail(r.field("emission_strength"), "makes the emitted radiance " + std::to_string(e) +
                                                 ", outside [1e-30, 1e30] (see the colour ranges)");
      emission[c] = float(e);
    }
  }
  Material m(name, std::move(bsdf), emission);
  if (m.isEmissive() || r.has("two_sided")) m.twoSidedEmission = r.boolean("two_sided", false);
  r.finish();
  return m;
}

}  // namespace lensfarm
