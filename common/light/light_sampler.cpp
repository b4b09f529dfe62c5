#include "light/light_sampler.h"

#include <algorithm>

#include "math/lanes.h"
#include "math/ray_offset.h"
#include "math/sampling.h"

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
    const float area = 0.5f * glm::length(glm::cross(t.v1 - t.v0, t.v2 - t.v0));
    const double p = double(area) * luminance(m.emission) * (m.twoSidedEmission ? 2.0 : 1.0);
    if (!(p > 0.0)) continue;
    lightOfTriangle_[k] = int32_t(lights_.size());
    lights_.push_back(Light{k, area, 0.0f, t.v0, t.v1, t.v2, t.n, positionErrorBound(t.magnitude), m.emission,
                            m.twoSidedEmission ? 1.0f : 0.0f});
    power.push_back(p);
    total += p;
  }
  double running = 0.0;
  for (size_t i = 0; i < lights_.size(); ++i) {
    lights_[i].pmf = float(power[i] / total);
    running += power[i] / total;
    cdf_.push_back(float(running));
  }
  if (!cdf_.empty()) cdf_.back() = 1.0f;
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
  s.radiance = twoSided == 0.0f && glm::dot(n, d) >= 0.0f ? Spectrum(0.0f) : emission;
  // Area density 1/A converted to solid angle: dist^2 / (cos A).
  s.pdf = pmf * s.dist2 / (s.cosLight * area);
  return s;
}

// The packet form's lane loop: every lane's triangle already gathered into arrays.
struct GatheredLights {
  alignas(64) float v0x[kPacketWidth], v0y[kPacketWidth], v0z[kPacketWidth];
  alignas(64) float v1x[kPacketWidth], v1y[kPacketWidth], v1z[kPacketWidth];
  alignas(64) float v2x[kPacketWidth], v2y[kPacketWidth], v2z[kPacketWidth];
  alignas(64) float pmf[kPacketWidth], area[kPacketWidth];
  alignas(64) float er[kPacketWidth], eg[kPacketWidth], eb[kPacketWidth];
  alignas(64) float twoSided[kPacketWidth];
  alignas(64) float dist2[kPacketWidth], cosLight[kPacketWidth];  // out, for valid()
};

LENSFARM_LANE_LOOPS void sampleLanes(GatheredLights& __restrict g, LightSampleLanes& __restrict l) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const TrianglePoint s = sampleTrianglePoint(
        Vec3(g.v0x[k], g.v0y[k], g.v0z[k]), Vec3(g.v1x[k], g.v1y[k], g.v1z[k]), Vec3(g.v2x[k], g.v2y[k], g.v2z[k]),
        Vec3(l.nx[k], l.ny[k], l.nz[k]), Vec3(l.refx[k], l.refy[k], l.refz[k]), Vec2(l.u0[k], l.u1[k]), g.pmf[k],
        g.area[k], Spectrum(g.er[k], g.eg[k], g.eb[k]), g.twoSided[k]);
    l.px[k] = s.p.x, l.py[k] = s.p.y, l.pz[k] = s.p.z;
    l.rr[k] = s.radiance.r, l.rg[k] = s.radiance.g, l.rb[k] = s.radiance.b;
    l.pdf[k] = s.pdf;
    g.dist2[k] = s.dist2, g.cosLight[k] = s.cosLight;
  }
}
}  // namespace

size_t LightSampler::choose(float uChoice) const {
  // The first cdf entry above uChoice (std::upper_bound). Few lights: count the entries at or
  // below it without branches, which a random uChoice would mispredict half the time.
  size_t i = 0;
  if (cdf_.size() <= 8)
    for (float c : cdf_) i += size_t(c <= uChoice);
  else
    i = size_t(std::upper_bound(cdf_.begin(), cdf_.end(), uChoice) - cdf_.begin());
  return std::min(i, lights_.size() - 1);
}

std::optional<LightSample> LightSampler::sample(const Vec3& ref, float uChoice, Vec2 uPoint) const {
  if (lights_.empty()) return std::nullopt;
  const Light& l = lights_[choose(uChoice)];
  const TrianglePoint s =
      sampleTrianglePoint(l.v0, l.v1, l.v2, l.n, ref, uPoint, l.pmf, l.area, l.emission, l.twoSided);
  if (!s.valid()) return std::nullopt;
  return LightSample{s.p, l.n, l.pError, s.radiance, s.pdf};
}

void LightSampler::sample(LightSampleLanes& lanes) const {
  if (lights_.empty()) {
    for (int& found : lanes.found) found = 0;
    return;
  }
  GatheredLights g;
  for (int k = 0; k < kPacketWidth; ++k) {
    // A lane not asked for computes on the first light (finite values) and stays not found.
    const Light& l = lanes.found[k] != 0 ? lights_[choose(lanes.uChoice[k])] : lights_[0];
    g.v0x[k] = l.v0.x, g.v0y[k] = l.v0.y, g.v0z[k] = l.v0.z;
    g.v1x[k] = l.v1.x, g.v1y[k] = l.v1.y, g.v1z[k] = l.v1.z;
    g.v2x[k] = l.v2.x, g.v2y[k] = l.v2.y, g.v2z[k] = l.v2.z;
    lanes.nx[k] = l.n.x, lanes.ny[k] = l.n.y, lanes.nz[k] = l.n.z;
    lanes.ex[k] = l.pError.x, lanes.ey[k] = l.pError.y, lanes.ez[k] = l.pError.z;
    g.pmf[k] = l.pmf, g.area[k] = l.area;
    g.er[k] = l.emission.r, g.eg[k] = l.emission.g, g.eb[k] = l.emission.b;
    g.twoSided[k] = l.twoSided;
  }
  sampleLanes(g, lanes);
  for (int k = 0; k < kPacketWidth; ++k) {
    const TrianglePoint s{{}, {}, lanes.pdf[k], g.dist2[k], g.cosLight[k]};
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
