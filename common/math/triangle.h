#pragma once
// A triangle's normal and area, computed so that they hold for triangles of any size a float can
// describe (docs/numerics.md, "Scale").
//
// In float, |cross(e1, e2)|^2 overflows once the edges pass about 4e9 (and underflows below
// about 1e-10), so a valid triangle 1e10 across would look degenerate and a tiny one would get a
// zero normal. The differences of float vertices and their cross product are therefore taken in
// double (exact for the differences, 2^-53 relative for the rest), and only the unit normal and
// the area come back in float. The loader's degenerate test and the ray caster's normal are one
// function, so a triangle the loader keeps always has a unit normal.
#include <cmath>
#include <optional>

#include "common/math/vec.h"

namespace lensfarm {

// The unnormalised normal cross(v1 - v0, v2 - v0), in double; its length is twice the area.
inline DVec3 triangleCross(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  const DVec3 a(v0);
  return glm::cross(DVec3(v1) - a, DVec3(v2) - a);
}

// The unit geometric normal (facing the counter-clockwise side), or nothing for a triangle of
// zero area (coincident or collinear vertices, as the float vertices stand).
inline std::optional<Vec3> triangleNormal(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  const DVec3 c = triangleCross(v0, v1, v2);
  const double length = glm::length(c);
  if (!(length > 0.0) || !std::isfinite(length)) return std::nullopt;
  return Vec3(c / length);
}

inline double triangleArea(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  return 0.5 * glm::length(triangleCross(v0, v1, v2));
}

// The barycentrics (b1, b2) of x's projection onto the triangle's plane: x = (1 - b1 - b2) v0 +
// b1 v1 + b2 v2 there (the ray caster's convention). (0, 0) for a triangle of zero area.
inline glm::dvec2 triangleBarycentrics(const DVec3& x, const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  const DVec3 a(v0), e1 = DVec3(v1) - a, e2 = DVec3(v2) - a, n = glm::cross(e1, e2), d = x - a;
  const double nn = glm::dot(n, n);
  if (!(nn > 0.0) || !std::isfinite(nn)) return glm::dvec2(0.0);
  return glm::dvec2(glm::dot(glm::cross(d, e2), n), glm::dot(glm::cross(e1, d), n)) / nn;
}

}  // namespace lensfarm
