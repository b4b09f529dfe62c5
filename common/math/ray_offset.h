#pragma once
// Spawning rays from a surface without hitting it again by rounding.
//
// A hit point computed in float carries an error of a few ulps of the coordinates involved, so
// a ray leaving it can re-intersect its own surface. A fixed epsilon fails at some scale (too
// small far from the origin, too large in millimetre scenes). Instead the origin is pushed along
// the geometric normal by a bound on the position error that scales with the magnitude of the
// triangle's coordinates (pbrt-v4 `OffsetRayOrigin`, Mitsuba's `p_err`), then rounded one more
// ulp away from the surface. See docs/numerics.md.
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "math/vec.h"

namespace lensfarm {

// Bound on the error of a hit point on a triangle whose vertices' largest absolute coordinate is
// `magnitude`. pbrt's bound for interpolating the vertices is gamma(7) per component; but Embree's
// hit test works on vertices translated to the ray origin, which mixes all three components, so a
// triangle lying in the plane z = 0 still has an error in z proportional to its x and y. The bound
// is therefore isotropic, with a margin for Embree's own arithmetic.
inline Vec3 positionErrorBound(float magnitude) {
  constexpr float kUlpsOfMagnitude = 32.0f * std::numeric_limits<float>::epsilon();
  return Vec3(magnitude * kUlpsOfMagnitude);
}

// The next float above / below v (std::nextafter towards +/- infinity, without the library
// call, which cost 2 % of render time): IEEE 754 floats of one sign are ordered like their bits.
inline float nextFloatUp(float v) {
  if (std::isinf(v) && v > 0.0f) return v;
  if (v == -0.0f) v = 0.0f;
  uint32_t bits = std::bit_cast<uint32_t>(v);
  bits = v >= 0.0f ? bits + 1 : bits - 1;
  return std::bit_cast<float>(bits);
}
inline float nextFloatDown(float v) { return -nextFloatUp(-v); }

// Moves p off the surface with geometric normal n (unit), to the side that w points to.
inline Vec3 offsetRayOrigin(const Vec3& p, const Vec3& n, const Vec3& err, const Vec3& w) {
  const float d = glm::dot(glm::abs(n), err);
  Vec3 offset = d * n;
  if (glm::dot(w, n) < 0.0f) offset = -offset;
  Vec3 po = p + offset;
  // Round away from p so the offset survives the addition.
  for (int i = 0; i < 3; ++i) {
    if (offset[i] > 0.0f)
      po[i] = nextFloatUp(po[i]);
    else if (offset[i] < 0.0f)
      po[i] = nextFloatDown(po[i]);
  }
  return po;
}

}  // namespace lensfarm
