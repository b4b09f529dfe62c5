#include "common/medium/equiangular.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfarm {

EquiangularSegment equiangularSegment(const Vec3& o, const Vec3& dir, float tMin, float tMax, const Vec3& x) {
  EquiangularSegment s;
  s.tMin = tMin;
  s.tMax = tMax;
  const DVec3 toLight = DVec3(x) - DVec3(o), direction(dir);
  s.delta = glm::dot(toLight, direction);
  // The perpendicular part, computed from the difference (not sqrt(|x - o|^2 - delta^2), which
  // cancels catastrophically for a light near the ray).
  const double scale =
      std::max({std::fabs(s.delta), double(std::fabs(tMin)), std::isfinite(tMax) ? double(std::fabs(tMax)) : 0.0});
  s.d = std::max(glm::length(toLight - s.delta * direction), double(kMinRelativeDistance) * std::max(scale, 1e-30));
  s.thetaA = std::atan((double(tMin) - s.delta) / s.d);
  s.thetaB = std::isfinite(tMax) ? std::atan((double(tMax) - s.delta) / s.d) : M_PI / 2;
  return s;
}

float sampleEquiangular(const EquiangularSegment& s, float u) {
  const double theta = s.thetaA + double(u) * (s.thetaB - s.thetaA);
  const double t = s.delta + s.d * std::tan(theta);
  // Rounding in tan may step just outside the segment (or past float's range near pi / 2).
  return float(std::clamp(t, double(s.tMin),
                          std::isfinite(s.tMax) ? double(s.tMax) : double(std::numeric_limits<float>::max())));
}

float equiangularPdf(const EquiangularSegment& s, float t) {
  if (!(t >= s.tMin && t <= s.tMax) || !(s.thetaB > s.thetaA)) return 0.0f;
  // In double: d^2 and (t - delta)^2 leave float's range at scene scales of 1e19.
  const double along = double(t) - s.delta;
  return float(s.d / ((s.thetaB - s.thetaA) * (s.d * s.d + along * along)));
}

}  // namespace lensfarm
