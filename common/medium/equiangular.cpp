#include "common/medium/equiangular.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfarm {

EquiangularSegment equiangularSegment(const Vec3& o, const Vec3& dir, float tMin, float tMax, const Vec3& x) {
  EquiangularSegment s;
  s.tMin = tMin;
  s.tMax = tMax;
  const Vec3 toLight = x - o;
  s.delta = glm::dot(toLight, dir);
  // The perpendicular part, computed from the difference (not sqrt(|x - o|^2 - delta^2), which
  // cancels catastrophically for a light near the ray).
  const float scale = std::max({std::fabs(s.delta), std::fabs(tMin), std::isfinite(tMax) ? std::fabs(tMax) : 0.0f});
  s.d = std::max(glm::length(toLight - s.delta * dir), kMinRelativeDistance * std::max(scale, 1e-30f));
  s.thetaA = std::atan((tMin - s.delta) / s.d);
  s.thetaB = std::isfinite(tMax) ? std::atan((tMax - s.delta) / s.d) : float(M_PI / 2);
  return s;
}

float sampleEquiangular(const EquiangularSegment& s, float u) {
  const float theta = s.thetaA + u * (s.thetaB - s.thetaA);
  const float t = s.delta + s.d * std::tan(theta);
  // Rounding in tan may step just outside the segment (or past float's range near pi / 2).
  return std::clamp(t, s.tMin, std::isfinite(s.tMax) ? s.tMax : std::numeric_limits<float>::max());
}

float equiangularPdf(const EquiangularSegment& s, float t) {
  if (!(t >= s.tMin && t <= s.tMax) || !(s.thetaB > s.thetaA)) return 0.0f;
  // In double: d^2 and (t - delta)^2 leave float's range at scene scales of 1e19.
  const double d = s.d, along = double(t) - double(s.delta);
  return float(d / ((double(s.thetaB) - double(s.thetaA)) * (d * d + along * along)));
}

}  // namespace lensfarm
