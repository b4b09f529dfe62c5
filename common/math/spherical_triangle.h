#pragma once
// A triangle as seen from a point: the spherical triangle its directions cover on the unit sphere
// around the point, its solid angle, and directions sampled uniformly over it (Arvo 1995,
// "Stratified Sampling of Spherical Triangles", SIGGRAPH).
//
// Sampling a light triangle uniformly by area gives directions of density d^2 / (A cos) per
// steradian, which is unbounded where the point is close to the triangle (d -> 0) or sees it at a
// grazing angle: a shading point a centimetre from a lamp gets estimates 10^4 times its mean. The
// uniform density over the solid angle, 1 / Omega, is bounded by construction, so a light sample
// taken this way weighs at most L cos(theta) Omega.
//
// Computed in double from the float vertices (the differences exact): the directions are unit
// vectors, so the result does not depend on the scene's scale or its distance from the origin
// (docs/numerics.md, "Scale").
#include <optional>

#include "common/math/vec.h"

namespace lensfarm {

struct SphericalTriangle {
  DVec3 a, b, c;      // unit directions from the point to the triangle's vertices
  double cosAlpha;    // the interior angle at a, between the arcs to b and to c
  double sinAlpha;    //
  double solidAngle;  // steradians: alpha + beta + gamma - pi (Girard)

  // The triangle (v0, v1, v2) seen from p; nothing where it covers no solid angle a double can
  // tell from zero (p in the triangle's plane, coincident or collinear vertices).
  static std::optional<SphericalTriangle> seen(const Vec3& p, const Vec3& v0, const Vec3& v1, const Vec3& v2);

  // A unit direction of density 1 / solidAngle over the spherical triangle, from u in [0, 1)^2.
  // A bijection of the square onto the triangle that keeps stratification: u.x chooses the
  // sub-triangle (a, b, c') of area u.x Omega, c' on the arc from a to c; u.y the point on the
  // arc from b to c' with its cosine to b uniform (which makes the density uniform).
  DVec3 sample(Vec2 u) const;
};

}  // namespace lensfarm
