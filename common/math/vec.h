#pragma once
// Small vocabulary over GLM shared by the whole renderer.
//
// Conventions (written once; docs/scene-format.md repeats them for scene authors):
//  - Scene units are whatever the scene file uses; nothing in the renderer assumes metres.
//    The camera's focal length, sensor size and focus distance are in the same units.
//  - Spectrum is linear RGB. Emitted radiance and the values stored in a sensor are radiance
//    in the scene's own (arbitrary) radiometric unit; albedos are in [0, 1].
//  - Directions are unit vectors unless a name says otherwise.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace lensfarm {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;
using Spectrum = glm::vec3;  // linear RGB

// An orthonormal frame (tangent, bitangent, normal) for moving directions between world space
// and a local space where the normal is +z.
struct Frame {
  Vec3 t, b, n;

  // Builds a frame around unit vector n (Duff et al. 2017, "Building an Orthonormal Basis,
  // Revisited"): branch-free and continuous except at n.z = -0 / +0.
  static Frame fromNormal(const Vec3& n) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    return Frame{Vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3(b, sign + n.y * n.y * a, -n.y), n};
  }
  Vec3 toWorld(const Vec3& v) const { return t * v.x + b * v.y + n * v.z; }
  Vec3 toLocal(const Vec3& v) const { return Vec3(glm::dot(v, t), glm::dot(v, b), glm::dot(v, n)); }
};

// The largest |component|: a vector's size per axis (bounds are per axis), never overflowing.
inline double largestAbs(const DVec3& v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); }

// The axis-aligned box [lo, hi] of `points` (lo > hi, an empty box, for none).
template <typename V>
std::pair<V, V> boundsOf(const std::vector<V>& points) {
  using T = typename V::value_type;
  V lo(std::numeric_limits<T>::max()), hi(-std::numeric_limits<T>::max());
  for (const V& p : points) lo = glm::min(lo, p), hi = glm::max(hi, p);
  return {lo, hi};
}

// Corner c (0 to 7) of the box [lo, hi]: bits 0, 1 and 2 of c pick hi's x, y and z.
template <typename V>
V boxCorner(const V& lo, const V& hi, int c) {
  return V((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
}

// The 3x3 cofactor matrix: det(m) times the inverse transpose, defined for any m. Normals
// transform with the inverse transpose; this has its direction (times sign(det)) and is scaled
// first so that no product overflows.
inline glm::dmat3 cofactorMatrix(glm::dmat3 m) {
  double largest = 0.0;
  for (int c = 0; c < 3; ++c) largest = std::max(largest, largestAbs(m[c]));
  if (largest > 0.0 && std::isfinite(largest)) m /= largest;
  return glm::dmat3(glm::cross(m[1], m[2]), glm::cross(m[2], m[0]), glm::cross(m[0], m[1]));
}

inline float luminance(const Spectrum& s) {
  // Rec. 709 / sRGB primaries.
  return 0.2126f * s.r + 0.7152f * s.g + 0.0722f * s.b;
}

inline bool isFinite(const Spectrum& s) { return std::isfinite(s.r) && std::isfinite(s.g) && std::isfinite(s.b); }

inline bool isBlack(const Spectrum& s) { return s.r == 0.0f && s.g == 0.0f && s.b == 0.0f; }

}  // namespace lensfarm
