#pragma once
// The interface every scattering model implements (one per header/source pair in material/:
// lambertian, mirror, dielectric, conductor, ...), and its conventions, written once:
//
//  - Directions are unit vectors pointing away from the surface: wo towards where the light goes
//    (the camera side of the path), wi towards where it comes from.
//  - `n` is the geometric normal turned to the side of wo (dot(n, wo) >= 0). `front` says whether
//    that side is the front face (the face whose normal is cross(v1 - v0, v2 - v0)): a
//    dielectric's outside, where its `ior` is entered from.
//  - evalCos returns f(wo, wi) |cos theta_i|, per RGB channel; pdf the solid-angle density with
//    which sample() returns wi. Both are 0 for delta lobes, which only sample() produces.
//  - sample() takes one number for the choice of lobe (uLobe) and two for the direction (u), all
//    in [0, 1), from the sampler's dimensions of the vertex (render/sampler.h, dims).
//  - A sample's weight is f |cos| / pdf (or the delta lobe's weight), with every discrete choice
//    already divided out, so a path multiplies its throughput by it.
// Colour mixing is the 2013 report's eq. 2: reflected = incident * reflectance, channel by channel.
#include <memory>
#include <optional>

#include "common/math/vec.h"

namespace lensfarm {

struct PrincipledModel;

class Medium;

struct MaterialSample {
  Vec3 wi;
  Spectrum weight;
  float pdf;      // solid-angle density; 0 for specular (delta) lobes
  bool specular;  // a delta lobe: no light sampling, no MIS
  // A refraction's n_transmitted / n_incident, whose 1/eta^2 radiance scaling the weight holds; 1
  // for every other sample (Russian roulette divides the scaling out: render/integrator.cpp).
  float eta = 1.0f;
  // Passed straight through a thin wall (a delta sample along -wo; BsdfTraits::thinWall): not a
  // scattering vertex. The volume path tracer crosses it as a null event, keeping the last
  // vertex's density for MIS and its bounce count, as shadow rays cross it attenuated.
  bool straight = false;
};

// What the renderer needs to know of a model before it shades with it (render/integrator.cpp,
// scene/effects.cpp): constant for a model's lifetime.
struct BsdfTraits {
  bool reflects = false;    // scatters some light (false: black; the path ends there)
  bool delta = false;       // every lobe is a delta: no light sampling; a "mirror" bounce (2013 report §4.5)
  bool lambertian = false;  // f = albedo / pi: the packet tracer's lane loops shade it without the Bsdf
  bool choosesLobe = true;  // sample() reads uLobe (false: the integrator need not draw it)
  // Scatters nothing and blocks nothing: a medium's index-matched boundary (material/interface.h),
  // which rays cross unchanged (only the volume path tracer meets it: render/volume_integrator.h).
  bool passesThrough = false;
  // Can send a path through the surface (glass, transmission, subsurface, an interface): a closed
  // mesh of it is no wall the effect analysis may seal things behind (scene/effects.cpp).
  bool transmits = false;
  // A thin wall that lets light straight through with a tint (smooth thin-walled transmission: a
  // window pane, glTF transmission without KHR_materials_volume): its straight part is a delta
  // sample marked `straight`, and Bsdf::straightTransmittance gives it to shadow rays, which
  // cross the wall attenuated instead of stopping (render/volume_integrator.h).
  bool thinWall = false;
  Spectrum albedo{0.0f};  // lambertian: its albedo
  // The effect the scene analysis reports for it (scene/effects.h): "mirror", "rippled mirror",
  // "glass", ...; empty for Lambertian.
  const char* effect = "";

  // The perfectly diffuse lobe of albedo `albedo` (material/lambertian.h).
  static BsdfTraits lambertianLobe(const Spectrum& albedo) {
    BsdfTraits t;
    t.reflects = !isBlack(albedo);
    t.lambertian = true;
    t.choosesLobe = false;
    t.albedo = albedo;
    return t;
  }
  // A model with lobes of finite width (rough and principled models), shown as `effect`.
  static BsdfTraits glossyLobes(bool reflects, const char* effectName) {
    BsdfTraits t;
    t.reflects = reflects;
    t.effect = effectName;
    return t;
  }
  // A model whose lobes are all deltas, scattering `weight` (black: nothing), shown as `effect`;
  // `choosesLobe`: it picks between several (glass: reflection or refraction).
  static BsdfTraits deltaLobes(const Spectrum& weight, const char* effectName, bool choosesLobe = false) {
    BsdfTraits t;
    t.reflects = !isBlack(weight);
    t.delta = true;
    t.choosesLobe = choosesLobe;
    t.effect = effectName;
    return t;
  }
};

class Bsdf {
 public:
  virtual ~Bsdf() = default;
  virtual BsdfTraits traits() const = 0;
  // f(wo, wi) |cos theta_i| (zero for delta lobes).
  virtual Spectrum evalCos(const Vec3& /*n*/, const Vec3& /*wo*/, const Vec3& /*wi*/, bool /*front*/) const {
    return Spectrum(0.0f);
  }
  // Density of sample() returning wi, in solid angle (zero for delta lobes).
  virtual float pdf(const Vec3& /*n*/, const Vec3& /*wo*/, const Vec3& /*wi*/, bool /*front*/) const { return 0.0f; }
  // An incident direction and its weight; nothing when the sample is absorbed.
  virtual std::optional<MaterialSample> sample(const Vec3& n, const Vec3& wo, float uLobe, Vec2 u,
                                               bool front) const = 0;
  // The medium the model implies behind its front face (subsurface scattering's), if any.
  virtual std::shared_ptr<const Medium> interiorMedium() const { return nullptr; }
  // A thin wall's straight transmittance from wo's side to the other (BsdfTraits::thinWall): the
  // expected weight of its `straight` samples; zero for every other model.
  virtual Spectrum straightTransmittance(const Vec3& /*n*/, const Vec3& /*wo*/) const { return Spectrum(0.0f); }
  // The probability q that sample() goes straight through at wo: a thin wall's sample() does so
  // exactly when uLobe < q (with weight straightTransmittance / q), so a path tracer can tell a
  // crossing from a vertex before it samples; zero for every other model.
  virtual float straightProbability(const Vec3& /*n*/, const Vec3& /*wo*/) const { return 0.0f; }
  // Whether the packet tracer's lane loops can shade the model (render/integrator.cpp): true for
  // a model whose formulas a PrincipledModel record holds (material/principled_model.h), which
  // it writes to `model`.
  virtual bool laneModel(PrincipledModel& /*model*/) const { return false; }
};

// Mirror reflection of wo about n.
inline Vec3 reflect(const Vec3& wo, const Vec3& n) { return 2.0f * glm::dot(wo, n) * n - wo; }

}  // namespace lensfarm
