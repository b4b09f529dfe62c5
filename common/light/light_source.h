#pragma once
// Lights that are not emitting triangles: point, spot and directional lights (a scene's `lights`
// beyond "quad") and the environment (docs/scene-format.md, "lights" and "environment"). Each
// type has its own header/source pair and registers once, in light_types.cpp; the light sampler
// (render/light_sampler.h) chooses among them and the emitting triangles by power.
//
// Units (written once): a scene's radiance unit is L (whatever `radiance` is in: W/(sr m^2) in a
// scene in metres and watts). Point and spot `intensity` is radiant intensity I in L x area (W/sr):
// a point at distance r receives E = I cos(theta) / r^2. Directional `irradiance` E is in
// L x steradian (W/m^2): what a surface facing the light receives. The environment's `radiance`
// (or its image's pixels times `strength`) is radiance, L.
// Photometric inputs (glTF's KHR_lights_punctual: candela for point and spot, lux for directional)
// are converted at kLumensPerWatt, the 683 lm/W that Blender's glTF exporter and importer use:
// I = cd / 683 W/sr, E = lx / 683 W/m^2; then a lamp keeps its balance with emissive surfaces,
// whose radiance both exporter and scene take as it is.
//
// Delta lights (a point, a spot, a sun without angular diameter) can only be reached by light
// samples: no ray hits them, and their light sample has no solid-angle density (weight 1, no
// MIS). Infinite lights (the environment, a directional light) lie beyond the scene: their light
// sample is a direction, and its shadow ray ends beyond the scene (SceneSphere). The environment and a sun with an
// angular diameter are also reached by rays that leave the scene (escaped()), weighed against their light samples by
// MIS.
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "common/light/light_bounds.h"
#include "common/math/ray_offset.h"
#include "common/math/vec.h"

namespace lensfarm {

class FieldReader;

// Luminous efficacy for photometric light units: lumens per watt (the peak of the photopic
// curve, 555 nm; the convention of Blender's glTF exporter, PBR_WATTS_TO_LUMENS).
inline constexpr double kLumensPerWatt = 683.0;

// A point on a light as seen from a shading point, for next-event estimation.
struct LightSample {
  Vec3 p;              // point on the light (for an infinite light: far along the direction, see above)
  Vec3 n;              // the light's geometric normal at p; zero for lights that are not surfaces
  Vec3 v0;             // with n and margin, the light triangle's SpawnPlane, for the shadow ray's end
  float margin;        // (n zero: the shadow ray ends at p itself, math/ray_offset.h)
  Spectrum radiance;   // arriving at the shading point (zero if it sees the back); a delta light's
                       // I / r^2 or E
  float pdf;           // solid-angle density at the shading point; for a delta light, only the
                       // probability of choosing it
  bool delta = false;  // a delta light: the sample's MIS weight is 1
  // The shadow ray (render/integrator.cpp): 0 for an emitting triangle, whose shadow ray is the
  // segment to p; else it is cast along the unit direction towards p and runs `reach` times the
  // distance: 1 for a point or spot, SceneSphere::kReach for an infinite light.
  float reach = 0.0f;
  // The density with which the light sampler's position() strategy (the light chosen by power,
  // the point uniform by area: render/light_sampler.h) gives this sample's point, over `pdf`: 1
  // unless a light tree chose the light by the shading point or the point was sampled by solid
  // angle; infinite where sample() cannot give it. Equiangular sampling, which takes its light
  // point from position(), weighs its samples by it.
  float positionPdfRatio = 1.0f;

  SpawnPlane plane() const { return SpawnPlane{v0, n, margin}; }
};

// The bounding sphere of the scene in render space (every triangle and the camera), for the
// power of infinite lights (pi r^2 times their irradiance) and the far end of their shadow rays.
struct SceneSphere {
  Vec3 center{0.0f};
  float radius = 0.0f;

  // The light sample of an infinite light in direction wi (unit) from `ref`: its point p lies r
  // along wi (far enough that p - ref gives wi back to float precision, since |ref| <= 2r) and its
  // shadow ray, cast along the unit direction, runs kReach times as far. A shading point lies
  // within the sphere, so the ray's end, 3r away, lies outside it (at least 2r from the centre),
  // even where the shadow ray stops 1e-4 short. Render space holds coordinates up to 1e18 per
  // axis, so r <= 1.8e18 and the far end lies within 5r <= 8.7e18 of the camera, its squared
  // length finite in single precision (docs/numerics.md).
  static constexpr float kReach = 3.0f;
  // The sphere around the box [lo, hi] (double): its centre and half-diagonal, rounded up so that
  // the float sphere still holds every point of the box.
  static SceneSphere around(const DVec3& lo, const DVec3& hi) {
    return SceneSphere{Vec3(0.5 * (lo + hi)), float(0.5 * glm::length(hi - lo) * (1.0 + 1e-6))};
  }
  LightSample infiniteSample(const Vec3& ref, const Vec3& wi, const Spectrum& radiance, float pdf, bool delta) const {
    const Vec3 p = ref + wi * radius;
    return LightSample{p, Vec3(0.0f), p, 0.0f, radiance, pdf, delta, kReach};
  }
};

class LightSource {
 public:
  explicit LightSource(std::string name) : name_(std::move(name)) {}
  virtual ~LightSource() = default;

  const std::string& name() const { return name_; }
  // The type as the scene file names it: "point", "spot", "directional", "environment".
  virtual const char* type() const = 0;
  // What the effect analysis reports of it, e.g. "sky.exr 2048x1024".
  virtual std::string describe() const = 0;

  // Only light samples reach it (a point, a spot, a sun without angular diameter).
  virtual bool isDelta() const = 0;
  // Rays that leave the scene reach it (the environment, a sun with an angular diameter).
  virtual bool isReachedByEscapedRays() const { return false; }

  // Its power over pi, in luminance: what the light sampler chooses lights by (an emitting
  // triangle's is A L, twice that when two-sided; the others' follow pbrt-v4's Phi()).
  virtual double powerOverPi(const SceneSphere& sphere) const = 0;

  // A light sample from `ref` with sample values u; pdf is the light's own density (1 for a delta
  // light), not yet multiplied by the probability of choosing it. Nothing where there is none.
  virtual std::optional<LightSample> sample(const Vec3& ref, Vec2 u, const SceneSphere& sphere) const = 0;
  // The one point every sample() of a light at a point lies on (a point, a spot), whatever ref
  // and u; nothing for the others (render/light_sampler.h, LightSampler::position).
  virtual std::optional<Vec3> position() const { return std::nullopt; }
  // Where it lies, how strongly and in which directions it emits, for the light tree
  // (light/light_bounds.h): for a light in the scene (a point, a spot); nothing for the infinite
  // lights, which the light sampler chooses by power alone.
  virtual std::optional<LightBounds> bounds() const { return std::nullopt; }

  // For lights reached by escaped rays: the radiance arriving along a ray that leaves the scene
  // in direction d (unit), and the solid-angle density with which sample() gives d.
  virtual Spectrum escaped(const Vec3& /*d*/) const { return Spectrum(0.0f); }
  virtual float pdf(const Vec3& /*d*/) const { return 0.0f; }

 private:
  std::string name_;
};

// What a light type's parser needs from the scene loader.
struct LightParseContext {
  std::string name;  // the entry's `name`, or "lights[i]"
  // A position in the file (world space) moved into render space, or an InputError naming field.
  std::function<Vec3(const DVec3& world, const std::string& field)> toRenderSpace;
};

}  // namespace lensfarm
