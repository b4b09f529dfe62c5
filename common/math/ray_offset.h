#pragma once
// Spawning rays from a surface without hitting it again by rounding.
//
// A hit point computed in float carries an error of a few ulps of the coordinates involved, so
// a ray leaving it can re-intersect its own surface. A fixed epsilon fails at some scale (too
// small far from the origin, too large in millimetre scenes). Instead the origin is pushed along
// the geometric normal by a bound on the position error that scales with the magnitude of the
// triangle's coordinates (pbrt-v4 `OffsetRayOrigin`, Mitsuba's `p_err`), then rounded one more
// ulp away from the surface. See docs/numerics.md.
#include <cmath>
#include <limits>

#include "math/vec.h"

namespace lensfarm {

// Bound on the error of a point interpolated from vertices whose largest absolute coordinates
// are `magnitude` (componentwise). gamma(n) = n eps / (1 - n eps) with n = 7 is pbrt's bound for
// barycentric interpolation; Embree's own hit computation adds a few more ulps, hence the margin.
inline Vec3 positionErrorBound(const Vec3& magnitude) {
  constexpr float kUlpsOfMagnitude = 32.0f * std::numeric_limits<float>::epsilon();
  return magnitude * kUlpsOfMagnitude;
}

// Moves p off the surface with geometric normal n (unit), to the side that w points to.
inline Vec3 offsetRayOrigin(const Vec3& p, const Vec3& n, const Vec3& err, const Vec3& w) {
  const float d = glm::dot(glm::abs(n), err);
  Vec3 offset = d * n;
  if (glm::dot(w, n) < 0.0f) offset = -offset;
  Vec3 po = p + offset;
  // Round away from p so the offset survives the addition.
  for (int i = 0; i < 3; ++i) {
    if (offset[i] > 0.0f)
      po[i] = std::nextafter(po[i], std::numeric_limits<float>::infinity());
    else if (offset[i] < 0.0f)
      po[i] = std::nextafter(po[i], -std::numeric_limits<float>::infinity());
  }
  return po;
}

}  // namespace lensfarm
