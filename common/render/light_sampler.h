#pragma once
// Next-event estimation's choice of a light: every triangle whose material emits (quads from
// `lights`, emissive meshes) and every other light of the scene (light/light_source.h: point,
// spot, directional, the environment), chosen with probability proportional to its power, then a
// point on it or a direction (the light's own sampling).
//
// The point on a triangle: uniform by area where the shading point is far from it, uniform by
// the solid angle it covers (math/spherical_triangle.h) where the shading point lies within
// kSolidAngleReach times the triangle's radius of its centroid. By area, the density per
// steradian is d^2 / (A cos), unbounded near the light: a ceiling a centimetre above a two-sided
// lamp gets estimates 10^4 times their mean (fireflies wherever paths reach it). By solid angle
// it is 1 / Omega and an estimate is at most L Omega cos; it costs a few libm calls in double,
// paid only near the light. The choice depends on the shading point alone, so pdf() makes it the
// same way for a ray that hits the light.
//
// An emissive texture multiplies a triangle's emission point by point: its power counts the
// texture's mean over the triangle (16 stratified lookups at load), the point is sampled as
// without it (the density a ray that hits it weighs against stays the triangle's), and the
// sample's radiance is the texture's value there. A triangle whose texture is black at every lookup is
// left to the rays that reach it (weight 1), which keeps the estimate unbiased whatever it hides.
//
// Power, in luminance and over pi (only ratios matter): an emitting triangle's is A L (doubled
// when two-sided, Phi = pi A L); the other lights' is LightSource::powerOverPi, which uses the
// scene's bounding sphere (SceneSphere: every triangle and the camera) for infinite lights. A
// scene whose only lights are emitting triangles chooses exactly as it always has (the same cdf,
// the same bits); only other lights bring in the combined choice, where a packet's lanes that
// choose one of them take the one-sample code (sample()) lane by lane.
//
// With a light tree (`tree`, where the effect analysis turns it on: scene/effects.h), the lights
// in the scene (emitting triangles, points and spots) are chosen by their importance at the
// shading point (render/light_tree.h): the infinite lights keep their share of the power, chosen
// by power among themselves, and the tree chooses within the rest. The probability of a light then
// depends on the shading point (`ref`), which pdf() takes too. position() chooses by power and
// the point by area always (it has no shading point); LightSample::positionPdfRatio relates its
// density to the light sample's.
//
// With the naive estimator (`deltaOnly`) only delta lights are sampled: nothing else can reach
// them, and every other light is counted where rays hit it (render/integrator.h).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "common/light/light_source.h"
#include "common/math/vec.h"
#include "common/render/light_tree.h"
#include "common/render/ray_caster.h"
#include "common/scene/scene.h"

namespace lensfarm {

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
  // Out, only where the scene has lights that are not triangles (LightSampler::hasOtherLights):
  // 1 where the sample is of a delta light (LightSample::delta), else 0; LightSample::reach.
  alignas(64) int delta[kPacketWidth];
  alignas(64) float reach[kPacketWidth];
};

class LightSampler {
 public:
  // `useful[m]` false: emitters of material m light nothing and are not sampled (empty: all are).
  // `deltaOnly`: sample only the delta lights (the naive estimator).
  // `tree`: choose the lights in the scene with a light tree.
  // `solidAngleReach`: a triangle's points are sampled by solid angle within this many times its
  // radius of its centroid (0: never; infinity: always).
  LightSampler(const Scene& scene, const RayCaster& caster, const std::vector<bool>& useful = {},
               bool deltaOnly = false, bool tree = false, float solidAngleReach = kSolidAngleReach);

  bool empty() const { return size() == 0; }
  size_t size() const { return lights_.size() + others_.size(); }  // the lights sampled
  // Whether a light sample may be of a delta light (LightSample::delta).
  bool hasDeltaLights() const { return hasDelta_; }
  // Whether some light sampled lies at points (emitting triangles, point and spot lights): only
  // those have a position() for equiangular sampling.
  bool hasPositionedLights() const { return !lights_.empty() || hasPositioned_; }
  // Whether lights other than triangles are sampled: only then does the lane form write the
  // lanes' delta and reach.
  bool hasOtherLights() const { return !others_.empty(); }
  // Whether a light tree chooses (then the probability of a light depends on the shading point).
  bool usesTree() const { return !tree_.empty(); }
  const LightTree& tree() const { return tree_; }
  // The lights that rays leaving the scene reach (the environment, a sun with a diameter), each
  // with the probability of choosing it for a light sample (0 where it is not sampled).
  struct EscapeLight {
    const LightSource* light;
    float pmf;
  };
  const std::vector<EscapeLight>& escapeLights() const { return escapeLights_; }
  const SceneSphere& sceneSphere() const { return sphere_; }

  // Samples a point on a light as seen from `ref`; nothing if the chosen point is degenerate.
  std::optional<LightSample> sample(const Vec3& ref, float uChoice, Vec2 uPoint) const;
  // The same for every lane of a packet: each lane gets the bits sample() gives it.
  void sample(LightSampleLanes& lanes) const;
  // The light position() chooses for uChoice, sampled from `ref` at the point position() gives:
  // its pdf is position()'s density (the light by power, the point by area); its positionPdfRatio
  // that density over the density with which sample() from ref gives the same point.
  std::optional<LightSample> samplePositioned(const Vec3& ref, float uChoice, Vec2 uPoint) const;
  // The point sample() gives for these numbers from every `ref`, where it does not depend on ref:
  // on an emitting triangle (uniform by area) or a light at a point. Nothing for the other lights
  // (directions, not points) and where there are none. Equiangular sampling towards a light
  // (render/volume_integrator.cpp) chooses the point before the shading point it lights.
  std::optional<Vec3> position(float uChoice, Vec2 uPoint) const;

  // Density (solid angle, at a point at distance `distance` in direction d from `ref`) with which
  // sample() from ref would have produced the point hit on emitting triangle `triangle` (RayCaster
  // index), and the density position()'s choice (by power, by area) gives it; 0 where the
  // triangle is not sampled.
  struct HitPdf {
    float pdf, byPower;
  };
  HitPdf pdfs(uint32_t triangle, const Vec3& ref, float distance, const Vec3& d) const;
  float pdf(uint32_t triangle, const Vec3& ref, float distance, const Vec3& d) const {
    return pdfs(triangle, ref, distance, d).pdf;
  }
  // The same for a ray leaving the scene in direction d and reaching escape light e.
  static float pdf(const EscapeLight& e, const Vec3& d) { return e.pmf > 0.0f ? e.pmf * e.light->pdf(d) : 0.0f; }

  // Radiance leaving triangle `triangle` towards -d (zero from the back of a one-sided light).
  Spectrum emitted(uint32_t triangle, const Vec3& d) const;

  // Whether emitting triangle `triangle` is sampled (render/light_tracer.h emits from these).
  bool samplesTriangle(uint32_t triangle) const {
    return triangle < lightOfTriangle_.size() && lightOfTriangle_[triangle] >= 0;
  }

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
    float twoSided;  // 1: emits from both faces; 0: from the front face only
    // 1: a precise triangle (render/precise_triangles.h), whose spawn plane is anchored at the
    // point sampled on it, as the caster anchors its hits; 0: at v0.
    float anchored;
    uint32_t material;  // its material, for an emissive texture
    float textured;     // 1: the material's emissive texture multiplies `emission` at each point
    // From a shading point closer than this (squared) to `centroid`, the point is sampled by
    // solid angle; else by area.
    Vec3 centroid;
    float solidAngleRadius2;

    // The spawn plane at point p of the triangle.
    SpawnPlane planeAt(const Vec3& p) const { return SpawnPlane{anchored > 0.0f ? p : v0, n, margin}; }
  };
  // The emitting triangles sampled, their pmf among every light sampled.
  const std::vector<Light>& triangleLights() const { return lights_; }
  // The emissive texture's value (RGB, >= 0) at the point of light l that uPoint samples uniformly
  // by area (as position() maps it); 1 without a texture.
  Spectrum emissiveTexture(const Light& l, Vec2 uPoint) const;
  // The same at barycentrics (b1, b2) of light l.
  Spectrum emissiveTextureAt(const Light& l, float b1, float b2) const;
  // Within this many times a triangle's radius (its farthest vertex from its centroid) of its
  // centroid, its points are sampled by solid angle (render.triangle_light_sampling "auto").
  static constexpr float kSolidAngleReach = 2.0f;
  static float solidAngleReachFor(TriangleLightSampling mode) {
    return mode == TriangleLightSampling::kAuto   ? kSolidAngleReach
           : mode == TriangleLightSampling::kArea ? 0.0f
                                                  : std::numeric_limits<float>::infinity();
  }
  // Whether sample() from ref takes light l's point by solid angle: within its reach, where l
  // emits towards ref (behind a one-sided light every point gives nothing: the cheaper map serves).
  static bool bySolidAngle(const Light& l, const Vec3& ref) {
    const Vec3 d = ref - l.centroid;
    return glm::dot(d, d) < l.solidAngleRadius2 && (l.twoSided != 0.0f || glm::dot(d, l.n) > 0.0f);
  }

 private:
  size_t choose(float uChoice) const;  // the light whose cdf interval holds uChoice
  // The light sample() chooses from ref and the probability of choosing it; nothing where none.
  struct Choice {
    size_t light;  // into lights_, then others_
    float pmf;
  };
  std::optional<Choice> chooseFrom(const Vec3& ref, float uChoice) const;
  float pmfFrom(const Vec3& ref, size_t light) const;  // chooseFrom's probability of `light`
  // A light sample of other light i (an index into others_), chosen with probability pmf.
  std::optional<LightSample> sampleOther(size_t i, const Vec3& ref, Vec2 uPoint, float pmf) const;
  // A light sample of emitting triangle i (an index into lights_), chosen with probability pmf,
  // its point by area or by solid angle (sample() chooses as bySolidAngle() says).
  std::optional<LightSample> sampleTriangleByArea(size_t i, const Vec3& ref, Vec2 uPoint, float pmf) const;
  std::optional<LightSample> sampleTriangleBySolidAngle(size_t i, const Vec3& ref, Vec2 uPoint, float pmf) const;
  // near[k] = 1 where lane k (found, its triangle chosen[k]) takes its point by solid angle.
  void nearLanes(const LightSampleLanes& lanes, const uint32_t* chosen, float* near) const;
  // The lane form's lanes whose light is sampled by solid angle (near[k] != 0) or textured take
  // the one-sample code's values; chosen[k] is each lane's triangle, pmf[k] its probability.
  void finishTriangleLanes(LightSampleLanes& lanes, const uint32_t* chosen, const float* pmf, const float* near) const;
  // The lane form with a tree or with other lights: each lane's choice (chooseFrom) is its own.
  void sampleChosenLanes(LightSampleLanes& lanes) const;
  // Lane k of the lane form takes light sample s (found 0 where there is none).
  static void putLane(LightSampleLanes& lanes, int k, const std::optional<LightSample>& s);
  float pmfByPower(size_t light) const {
    return light < lights_.size() ? lights_[light].pmf : others_[light - lights_.size()].pmf;
  }
  void buildTree(const std::vector<double>& power);
  // With a tree: whether `light` is an infinite light, chosen by power before the tree.
  bool chosenFirst(size_t light) const {
    return light >= lights_.size() && std::binary_search(infinite_.begin(), infinite_.end(), light - lights_.size());
  }
  void sampleTriangleLanes(LightSampleLanes& lanes) const;  // the lane form without them
  // The texture's mean over triangle k of the caster (for its power).
  float meanEmissiveTexture(uint32_t k, const TextureRef& texture) const;

  const Scene& scene_;
  const RayCaster& caster_;
  std::vector<Light> lights_;  // the emitting triangles; in the cdf first, by index
  struct Other {
    const LightSource* light;
    float pmf;
  };
  std::vector<Other> others_;             // the other lights; in the cdf after the triangles
  std::vector<float> cdf_;                // cumulative pmf, cdf_.back() == 1
  float fewCdf_[kFewLights];              // cdf_ padded with 2 (above any uChoice), up to kFewLights lights
  std::vector<int32_t> lightOfTriangle_;  // per RayCaster triangle, -1 if not emitting
  SceneSphere sphere_;
  std::vector<EscapeLight> escapeLights_;
  // With a tree: the infinite lights (into others_), their cumulative pmf (by power, summing to
  // infinitePmf_), and the tree over the rest (ids: the light index of Choice).
  std::vector<size_t> infinite_;  // ascending
  std::vector<float> infiniteCdf_;
  float infinitePmf_ = 0.0f;
  LightTree tree_;
  bool hasDelta_ = false;
  bool hasPositioned_ = false;
  bool hasTextured_ = false;  // some light is an emitting triangle with an emissive texture
  // The box of every triangle's reach (where its points may be sampled by solid angle).
  Vec3 reachLo_{std::numeric_limits<float>::infinity()}, reachHi_{-std::numeric_limits<float>::infinity()};
};

// The bounding sphere of the caster's triangles and the camera (render space's origin).
SceneSphere sceneSphereOf(const RayCaster& caster);

}  // namespace lensfarm
