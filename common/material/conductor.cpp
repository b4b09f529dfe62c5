#include "material/conductor.h"

#include <string>

#include "material/fresnel.h"
#include "scene/field_reader.h"

namespace lensfarm {

namespace {
// A conductor's complex index eta + i k per channel: real metals have eta from about 0.05 (silver)
// to a few, and k up to about 10 (aluminium in the blue is 4.8, in the infrared more).
constexpr ColorRange kConductorEtaRange{0.01, 10.0, "an index below 0.01 is not a metal in the visible",
                                        "an index above 10 is not a material in the visible"};
constexpr ColorRange kConductorKRange{1e-6, 100.0, "an extinction coefficient below 1e-6 is a dielectric: write 0",
                                      "an extinction coefficient above 100 is not a material in the visible"};

// Named metals for `conductor.metal`: eta and k at about 650, 550 and 450 nm (the red, green and
// blue primaries), from measured optical constants (Au, Ag, Cu: Johnson & Christy 1972; Al:
// Rakic 1995; as tabulated by refractiveindex.info).
struct NamedMetal {
  const char* name;
  Spectrum eta, k;
};
constexpr NamedMetal kNamedMetals[] = {
    {"Au", {0.143f, 0.374f, 1.442f}, {3.983f, 2.385f, 1.603f}},
    {"Ag", {0.155f, 0.117f, 0.138f}, {4.828f, 3.122f, 2.147f}},
    {"Cu", {0.200f, 0.924f, 1.102f}, {3.912f, 2.452f, 2.142f}},
    {"Al", {1.657f, 0.880f, 0.521f}, {9.224f, 6.270f, 4.837f}},
};
}  // namespace

bool namedMetal(const std::string& name, Spectrum& eta, Spectrum& k) {
  for (const NamedMetal& m : kNamedMetals)
    if (name == m.name) {
      eta = m.eta, k = m.k;
      return true;
    }
  return false;
}

BsdfTraits ConductorBsdf::traits() const { return BsdfTraits::deltaLobes(tint_, "metal"); }

Spectrum ConductorBsdf::fresnel(float cosI) const {
  return Spectrum(fresnelConductor(cosI, eta_.r, k_.r), fresnelConductor(cosI, eta_.g, k_.g),
                  fresnelConductor(cosI, eta_.b, k_.b));
}

std::optional<MaterialSample> ConductorBsdf::sample(const Vec3& n, const Vec3& wo, float /*uLobe*/, Vec2 /*u*/,
                                                    bool /*front*/) const {
  return MaterialSample{reflect(wo, n), tint_ * fresnel(glm::dot(n, wo)), 0.0f, true};
}

std::shared_ptr<const Bsdf> parseConductor(FieldReader& r) {
  const Spectrum tint = r.color("tint", Spectrum(1.0f), kReflectanceRange);
  if (r.has("metal") == (r.has("eta") || r.has("k")))
    r.fail(r.field("metal"), "give either metal (Au, Ag, Cu or Al) or eta and k");
  Spectrum eta, k;
  if (r.has("metal")) {
    const std::string metal = r.string("metal");
    if (!namedMetal(metal, eta, k)) r.fail(r.field("metal"), "unknown metal \"" + metal + "\" (expected Au, Ag, Cu or Al)");
  } else {
    eta = r.color("eta", kConductorEtaRange);
    k = r.color("k", kConductorKRange);
  }
  for (int c = 0; c < 3; ++c)
    if (eta[c] == 0.0f) r.fail(r.field("eta"), "must be > 0 in every channel");
  return std::make_shared<ConductorBsdf>(eta, k, tint);
}

}  // namespace lensfarm
