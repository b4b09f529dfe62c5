#pragma once
// Area lights: every triangle whose material emits (quads from `lights`, emissive meshes).
// Next-event estimation picks one emitting triangle with probability proportional to its power
// (area x luminance of the emitted radiance, doubled when two-sided) and a uniform point on it.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "math/vec.h"
#include "render/ray_caster.h"
#include "scene/scene.h"

namespace lensfarm {

struct LightSample {
  Vec3 p;            // point on the light
  Vec3 n;            // the light's geometric normal at p
  Vec3 v0;           // with n and margin, the light triangle's SpawnPlane, for the shadow ray's end
  float margin;
  Spectrum radiance; // emitted towards the shading point (zero if it sees the back)
  float pdf;         // solid-angle density at the shading point

  SpawnPlane plane() const { return SpawnPlane{v0, n, margin}; }
};

// sample() for the lanes of a packet at once, as arrays over the lanes (render/integrator.h).
struct LightSampleLanes {
  // In: found[k] != 0 for each lane to sample, with its sample values and reference point.
  alignas(64) int found[kPacketWidth];
  alignas(64) float uChoice[kPacketWidth], u0[kPacketWidth], u1[kPacketWidth];
  alignas(64) float refx[kPacketWidth], refy[kPacketWidth], refz[kPacketWidth];
  // Out: found[k] is -1 where sample() returns a sample and 0 elsewhere; the fields of LightSample.
  alignas(64) float px[kPacketWidth], py[kPacketWidth], pz[kPacketWidth];
  alignas(64) float nx[kPacketWidth], ny[kPacketWidth], nz[kPacketWidth];
  alignas(64) float v0x[kPacketWidth], v0y[kPacketWidth], v0z[kPacketWidth];
  alignas(64) float margin[kPacketWidth];
  alignas(64) float rr[kPacketWidth], rg[kPacketWidth], rb[kPacketWidth];
  alignas(64) float pdf[kPacketWidth];
};

class LightSampler {
 public:
  // `useful[m]` false: emitters of material m light nothing and are not sampled (empty: all are).
  LightSampler(const Scene& scene, const RayCaster& caster, const std::vector<bool>& useful = {});

  bool empty() const { return lights_.empty(); }
  size_t size() const { return lights_.size(); }

  // Samples a point on a light as seen from `ref`; nothing if the chosen point is degenerate.
  std::optional<LightSample> sample(const Vec3& ref, float uChoice, Vec2 uPoint) const;
  // The same for every lane of a packet: each lane gets the bits sample() gives it.
  void sample(LightSampleLanes& lanes) const;

  // Density (solid angle, at a point at distance `distance` in direction d) with which sample()
  // would have produced the point hit on emitting triangle `triangle` (RayCaster index).
  float pdf(uint32_t triangle, float distance, const Vec3& d) const;

  // Radiance leaving triangle `triangle` towards -d (zero from the back of a one-sided light).
  Spectrum emitted(uint32_t triangle, const Vec3& d) const;

  // Up to this many lights, a light is chosen without a search (and in the packet form's lane loop).
  static constexpr size_t kFewLights = 8;
  // Everything sampling needs of one emitting triangle, in one place (the packet form gathers
  // it for 16 lanes per vertex).
  struct Light {
    uint32_t triangle;
    float area;
    float pmf;
    Vec3 v0, v1, v2, n;  // the triangle (RayCaster::Triangle) and its geometric normal
    float margin;        // with v0 and n, the triangle's SpawnPlane (math/ray_offset.h)
    Spectrum emission;
    float twoSided;      // 1: emits from both faces; 0: from the front face only
  };

 private:
  size_t choose(float uChoice) const;  // the light whose cdf interval holds uChoice

  const Scene& scene_;
  const RayCaster& caster_;
  std::vector<Light> lights_;
  std::vector<float> cdf_;            // cumulative pmf, cdf_.back() == 1
  float fewCdf_[kFewLights];  // cdf_ padded with 2 (above any uChoice), up to kFewLights lights
  std::vector<int32_t> lightOfTriangle_;  // per RayCaster triangle, -1 if not emitting
};

}  // namespace lensfarm
