#include "light/light_sampler.h"

#include <algorithm>
#include <bit>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "math/lanes.h"
#include "math/ray_offset.h"
#include "math/sampling.h"
#include "math/triangle.h"

namespace lensfarm {

LightSampler::LightSampler(const Scene& scene, const RayCaster& caster, const std::vector<bool>& useful)
    : scene_(scene), caster_(caster) {
  const auto& triangles = caster.triangles();
  lightOfTriangle_.assign(triangles.size(), -1);
  double total = 0.0;
  std::vector<double> power;
  for (uint32_t k = 0; k < triangles.size(); ++k) {
    const auto& t = triangles[k];
    const Material& m = scene.materials[t.material];
    if (!m.isEmissive() || (!useful.empty() && !useful[t.material])) continue;
    const float area = float(triangleArea(t.v0, t.v1, t.v2));
    const double p = double(area) * luminance(m.emission) * (m.twoSidedEmission ? 2.0 : 1.0);
    if (!(p > 0.0)) continue;
    lightOfTriangle_[k] = int32_t(lights_.size());
    lights_.push_back(Light{k, area, 0.0f, t.v0, t.v1, t.v2, t.n, t.margin, m.emission,
                            m.twoSidedEmission ? 1.0f : 0.0f});
    power.push_back(p);
    total += p;
  }
  if (lights_.size() > GatherView<Light>::kMaxRecords)  // the packet form's lane loop indexes them with 32 bits
    throw std::runtime_error("the scene has " + std::to_string(lights_.size()) + " emitting triangles; at most " +
                             std::to_string(GatherView<Light>::kMaxRecords) + " are supported");
  double running = 0.0;
  for (size_t i = 0; i < lights_.size(); ++i) {
    lights_[i].pmf = float(power[i] / total);
    running += power[i] / total;
    cdf_.push_back(float(running));
  }
  if (!cdf_.empty()) cdf_.back() = 1.0f;
  for (size_t i = 0; i < kFewLights; ++i) fewCdf_[i] = i < cdf_.size() ? cdf_[i] : 2.0f;  // above any uChoice
}

namespace {
// One light sample on a triangle, as seen from ref: the formula both sample() and the packet form
// below evaluate, without branches, so a loop over lanes vectorises (math/lanes.h).
struct TrianglePoint {
  Vec3 p;
  Spectrum radiance;
  float pdf;
  float dist2, cosLight;
  // Whether there is a sample at all: not for a degenerate point or direction, nor an infinite
  // density. (Tested outside lane loops: a flag computed inside one keeps it scalar.)
  bool valid() const { return dist2 > 0.0f && cosLight > 0.0f && std::isfinite(pdf); }
};

inline TrianglePoint sampleTrianglePoint(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& n, const Vec3& ref,
                                         Vec2 u, float pmf, float area, const Spectrum& emission, float twoSided) {
  const Vec2 b = sampleUniformTriangle(u);
  TrianglePoint s;
  s.p = b.x * v0 + b.y * v1 + (1.0f - b.x - b.y) * v2;
  const Vec3 toLight = s.p - ref;
  s.dist2 = glm::dot(toLight, toLight);
  const Vec3 d = toLight * (1.0f / std::sqrt(s.dist2));  // one division, not three
  s.cosLight = std::abs(glm::dot(n, d));
  // Emitted towards ref, zero where ref sees the back of a one-sided light.
  // (A product, not a select between emission and zero: the packet form gathers `emission` from
  // the lane's light, and a select would load it only in one branch, which keeps the loop scalar.)
  const float facing = twoSided != 0.0f || !(glm::dot(n, d) >= 0.0f) ? 1.0f : 0.0f;
  s.radiance = emission * facing;
  // Area density 1/A converted to solid angle: dist^2 / (cos A).
  s.pdf = pmf * s.dist2 / (s.cosLight * area);
  return s;
}

// Few lights: the cdf padded to a fixed length with entries no uChoice reaches, so choosing is
// a count without branches (a random uChoice would mispredict a search half the time) and the
// packet form's lane loop can choose for every lane.
inline uint32_t chooseAmongFew(const float (&cdf)[LightSampler::kFewLights], float uChoice) {
  uint32_t i = 0;
#pragma GCC unroll 8
  for (float c : cdf) i += uint32_t(c <= uChoice);
  return i;
}

// Up to kLights lights held by value for a lane loop: a lane's field of light i is picked with
// selects between that field of each light (loads at fixed places, hoisted out of the loop), not
// gathered lane by lane. Lights beyond the scene's repeat the first.
using Light = LightSampler::Light;
class SelectView {
 public:
  static constexpr uint32_t kLights = 4;
  SelectView(const Light* lights, size_t count) {
    for (uint32_t j = 0; j < kLights; ++j) lights_[j] = lights[j < count ? j : 0];
  }
  float f(uint32_t i, size_t offset) const {
    float x = at(0, offset);
#pragma GCC unroll 4
    for (uint32_t j = 1; j < kLights; ++j) x = i == j ? at(j, offset) : x;
    return x;
  }
  Vec3 vec3(uint32_t i, size_t offset) const {
    return Vec3(f(i, offset), f(i, offset + sizeof(float)), f(i, offset + 2 * sizeof(float)));
  }

 private:
  float at(uint32_t j, size_t offset) const { return reinterpret_cast<const float*>(&lights_[j])[offset / sizeof(float)]; }
  Light lights_[kLights];
};

// The packet form's lane loops: lane k samples a point on light i, read from `lights` (a
// GatherView or a SelectView).
template <typename Lights>
[[gnu::always_inline]] inline void sampleLane(Lights lights, uint32_t i, int k, LightSampleLanes& l, float* dist2, float* cosLight) {
  const Vec3 n = lights.vec3(i, offsetof(Light, n)), v0 = lights.vec3(i, offsetof(Light, v0));
  const TrianglePoint s = sampleTrianglePoint(
      lights.vec3(i, offsetof(Light, v0)), lights.vec3(i, offsetof(Light, v1)), lights.vec3(i, offsetof(Light, v2)), n,
      Vec3(l.refx[k], l.refy[k], l.refz[k]), Vec2(l.u0[k], l.u1[k]), lights.f(i, offsetof(Light, pmf)),
      lights.f(i, offsetof(Light, area)), lights.vec3(i, offsetof(Light, emission)), lights.f(i, offsetof(Light, twoSided)));
  l.px[k] = s.p.x, l.py[k] = s.p.y, l.pz[k] = s.p.z;
  l.nx[k] = n.x, l.ny[k] = n.y, l.nz[k] = n.z;
  l.v0x[k] = v0.x, l.v0y[k] = v0.y, l.v0z[k] = v0.z;
  l.margin[k] = lights.f(i, offsetof(Light, margin));
  l.rr[k] = s.radiance.r, l.rg[k] = s.radiance.g, l.rb[k] = s.radiance.b;
  l.pdf[k] = s.pdf;
  dist2[k] = s.dist2, cosLight[k] = s.cosLight;
}

// Up to SelectView::kLights lights: each lane chooses its light and reads it with selects.
// Without branches, so the loops vectorise; lanes not asked for take light 0.
LENSFARM_LANE_LOOPS void sampleSelectedLanes(SelectView lights, uint32_t lastLight,
                                             const float (&cdf)[LightSampler::kFewLights], LightSampleLanes& __restrict l,
                                             float* __restrict dist2, float* __restrict cosLight) {
  float fewCdf[LightSampler::kFewLights];  // a copy nothing else can write (else GCC checks aliasing)
  std::copy(std::begin(cdf), std::end(cdf), fewCdf);
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t i = std::min(chooseAmongFew(fewCdf, l.uChoice[k]), lastLight) & uint32_t(l.found[k]);
    sampleLane(lights, i, k, l, dist2, cosLight);
  }
}

// More lights: each lane gathers its light, chosen before the loop (`chosen`).
LENSFARM_LANE_LOOPS void sampleGatheredLanes(GatherView<Light> lights, const uint32_t* __restrict chosen,
                                             LightSampleLanes& __restrict l, float* __restrict dist2,
                                             float* __restrict cosLight) {
  for (int k = 0; k < kPacketWidth; ++k) sampleLane(lights, chosen[k], k, l, dist2, cosLight);
}
}  // namespace

size_t LightSampler::choose(float uChoice) const {
  // The first cdf entry above uChoice (std::upper_bound).
  const size_t i = lights_.size() <= kFewLights
                       ? chooseAmongFew(fewCdf_, uChoice)
                       : size_t(std::upper_bound(cdf_.begin(), cdf_.end(), uChoice) - cdf_.begin());
  return std::min(i, lights_.size() - 1);
}

std::optional<LightSample> LightSampler::sample(const Vec3& ref, float uChoice, Vec2 uPoint) const {
  if (lights_.empty()) return std::nullopt;
  const Light& l = lights_[choose(uChoice)];
  const TrianglePoint s =
      sampleTrianglePoint(l.v0, l.v1, l.v2, l.n, ref, uPoint, l.pmf, l.area, l.emission, l.twoSided);
  if (!s.valid()) return std::nullopt;
  return LightSample{s.p, l.n, l.v0, l.margin, s.radiance, s.pdf};
}

void LightSampler::sample(LightSampleLanes& lanes) const {
  if (lights_.empty()) {
    for (int& found : lanes.found) found = 0;
    return;
  }
  // A lane not asked for computes on the first light (finite values) and stays not found.
  alignas(64) float dist2[kPacketWidth], cosLight[kPacketWidth];
  if (lights_.size() <= SelectView::kLights) {
    sampleSelectedLanes(SelectView(lights_.data(), lights_.size()), uint32_t(lights_.size() - 1), fewCdf_, lanes, dist2,
                        cosLight);
  } else {
    alignas(64) uint32_t chosen[kPacketWidth];
    for (int k = 0; k < kPacketWidth; ++k) chosen[k] = lanes.found[k] != 0 ? uint32_t(choose(lanes.uChoice[k])) : 0u;
    sampleGatheredLanes(GatherView<Light>(lights_.data()), chosen, lanes, dist2, cosLight);
  }
  for (int k = 0; k < kPacketWidth; ++k) {
    const TrianglePoint s{{}, {}, lanes.pdf[k], dist2[k], cosLight[k]};
    if (!s.valid()) lanes.found[k] = 0;
  }
}

float LightSampler::pdf(uint32_t triangle, float distance, const Vec3& d) const {
  const int32_t i = lightOfTriangle_[triangle];
  if (i < 0) return 0.0f;
  const Light& light = lights_[i];
  const float cosLight = std::abs(glm::dot(caster_.triangles()[triangle].n, d));
  if (!(cosLight > 0.0f)) return 0.0f;
  return light.pmf * distance * distance / (cosLight * light.area);
}

Spectrum LightSampler::emitted(uint32_t triangle, const Vec3& d) const {
  const auto& t = caster_.triangles()[triangle];
  const Material& m = scene_.materials[t.material];
  if (!m.twoSidedEmission && glm::dot(t.n, d) >= 0.0f) return Spectrum(0.0f);  // seen from behind
  return m.emission;
}

}  // namespace lensfarm
