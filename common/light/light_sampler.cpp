#include "light/light_sampler.h"

#include <algorithm>

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
    lights_.push_back(Light{k, area, 0.0f});
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

std::optional<LightSample> LightSampler::sample(const Vec3& ref, float uChoice, Vec2 uPoint) const {
  if (lights_.empty()) return std::nullopt;
  const size_t i = std::min<size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), uChoice) - cdf_.begin(), lights_.size() - 1);
  const Light& light = lights_[i];
  const auto& t = caster_.triangles()[light.triangle];
  const Vec2 b = sampleUniformTriangle(uPoint);
  LightSample s;
  s.p = b.x * t.v0 + b.y * t.v1 + (1.0f - b.x - b.y) * t.v2;
  s.n = t.n;
  s.pError = positionErrorBound(t.magnitude);
  const Vec3 toLight = s.p - ref;
  const float dist2 = glm::dot(toLight, toLight);
  if (!(dist2 > 0.0f)) return std::nullopt;
  const Vec3 d = toLight * (1.0f / std::sqrt(dist2));  // one division, not three
  const float cosLight = std::abs(glm::dot(s.n, d));
  if (!(cosLight > 0.0f)) return std::nullopt;
  s.radiance = emitted(light.triangle, d);
  // Area density 1/A converted to solid angle: dist^2 / (cos A).
  s.pdf = light.pmf * dist2 / (cosLight * light.area);
  if (!std::isfinite(s.pdf)) return std::nullopt;
  return s;
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
