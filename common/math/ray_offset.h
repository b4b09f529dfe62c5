#pragma once
// Spawning rays from a surface without hitting it again by rounding, and without jumping over a
// nearby one (docs/numerics.md, "Self-intersection" and "Thin gaps").
//
// A ray leaving a triangle must start on the side it leaves to, far enough from the triangle's
// plane that Embree's own intersection test cannot mistake it for a hit; and no farther, or it
// may start beyond a surface lying just above (a shelf over a floor). The distance is therefore
// measured from the hit's own triangle, not the scene's extent:
//
//  1. Embree's robust test translates the vertices to the ray origin and rounds (differences of
//     size L, the longest edge) and takes a cross product of the edges, whose direction is off by
//     about eps / sin(angle) for the best-conditioned pair of edges. Its error in the distance of
//     the origin from the plane is therefore c eps L / max sin(angle); measured over 10^7 rays
//     on well-shaped, thin and needle triangles at 0 to 1000 edge lengths from the origin, zero
//     self-hits from c = 0.75 on (tests/numerics: SelfIntersection.*). The margin uses c = 2.
//  2. The origin is placed in double at that margin from the triangle's plane, measured from a
//     vertex with the float unit normal (whose rounding, at most eps/2, tilts the plane by at
//     most eps L / 2 over the triangle: added to the margin), plus the most that rounding the
//     origin to float can move it (half an ulp per coordinate).
//
// The offset is thus a few ulps of the triangle's own size plus one of the point's coordinates:
// at the origin of render space (the camera, scene/scene.h) a floor and a shelf 10^-6 of the
// floor's size apart stay apart (tests/numerics: ThinGaps.*).
#include <cmath>
#include <limits>

#include "common/math/vec.h"

namespace lensfarm {

// What spawning from a point of a triangle needs of the triangle: a vertex, its unit normal and
// the margin.
struct SpawnPlane {
  Vec3 v0;
  Vec3 n;        // unit geometric normal: the triangle's n
  float margin;  // distance from the plane that Embree's test resolves, and n's rounding (above)
};

// The spawn plane of the float triangle (v0, v1, v2), whose area must not be zero.
inline SpawnPlane spawnPlaneOf(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  const DVec3 a(v0), b(v1), c(v2);
  const DVec3 cross = glm::cross(b - a, c - a);
  const DVec3 n = cross / glm::length(cross);
  const DVec3 e[3] = {b - a, c - b, a - c};
  const double len[3] = {glm::length(e[0]), glm::length(e[1]), glm::length(e[2])};
  const double longest = std::max(len[0], std::max(len[1], len[2]));
  // sin of the angle at each vertex: |cross| / (product of the two edges meeting there).
  const double twiceArea = glm::length(cross);
  const double bestSin =
      std::max(twiceArea / (len[0] * len[2]), std::max(twiceArea / (len[0] * len[1]), twiceArea / (len[1] * len[2])));
  constexpr double kEmbreeUlps = 2.0, kNormalUlps = 0.5;
  const double margin =
      (kEmbreeUlps / std::min(1.0, bestSin) + kNormalUlps) * double(std::numeric_limits<float>::epsilon()) * longest;
  return SpawnPlane{v0, Vec3(n), float(margin)};
}

inline constexpr double kGrazingMargin = 8.0;

// The origin for a ray in direction w leaving point p (on the plane's triangle, in float): on
// the side w points to, at least `margin` from the plane after rounding. Branch-free, so the
// packet tracer's lane loops vectorise it.
inline Vec3 spawnOrigin(const Vec3& p, const Vec3& v0, const Vec3& nf, float margin, const Vec3& w) {
  const DVec3 n(nf);
  const DVec3 pd(p);
  // p's signed distance from the plane: the differences of floats are exact in double.
  const double s = glm::dot(n, pd - DVec3(v0));
  // Rounding the result to float moves coordinate i by at most half an ulp, <= 2^-24 |x_i|;
  // bounded with a factor two to spare, and never below the smallest subnormal.
  const double rounding = double(std::numeric_limits<float>::epsilon()) *
                              (std::abs(p.x * n.x) + std::abs(p.y * n.y) + std::abs(p.z * n.z)) +
                          double(std::numeric_limits<float>::denorm_min());
  // The side w points to, judged in double too: a direction within float rounding of the plane
  // (about 1e-7 rad) leaves to the side it truly points to, so it never crosses its own triangle.
  const double cosine = glm::dot(DVec3(w), n) / glm::length(DVec3(w));
  const double side = cosine < 0.0 ? -1.0 : 1.0;
  // A ray within a few ulps of parallel to the plane: Embree's denominator dot(Ng, d) is then
  // rounding noise and may take the wrong sign, which reports a hit where the ray's line meets
  // the plane, about margin / (eps |Ng|) away. A margin GRAZE times larger puts that point beyond
  // the triangle. Only rays within 16 eps (2e-6 rad) of the plane pay for it.
  const double graze = std::abs(cosine) < 16.0 * double(std::numeric_limits<float>::epsilon()) ? kGrazingMargin : 1.0;
  return Vec3(pd + (side * (graze * double(margin) + rounding) - s) * n);
}
inline Vec3 spawnOrigin(const Vec3& p, const SpawnPlane& plane, const Vec3& w) {
  return spawnOrigin(p, plane.v0, plane.n, plane.margin, w);
}

}  // namespace lensfarm
