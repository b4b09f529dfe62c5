#pragma once
// Equiangular sampling of a distance along a ray towards a point (Kulla & Fajardo 2012,
// "Importance Sampling Techniques for Path Tracing in Participating Media", EGSR, §4.1): in fog
// lit by a small light, the light reaching a point of the ray falls as 1 / r^2 with its distance
// r to the light, which distance sampling (proportional to transmittance) does not follow, so
// points near the light are found rarely and weigh much: speckles. Sampling t with a density
// proportional to 1 / r(t)^2 instead cancels that factor.
//
// With the ray o + t dir (dir unit), the light point x, delta = dot(x - o, dir) the distance along
// the ray to the point nearest x and D = |x - (o + delta dir)| the distance from the ray to x,
//     r(t)^2 = D^2 + (t - delta)^2,   t = delta + D tan(theta),
// and theta uniform in [theta_a, theta_b] (the angles of tMin and tMax) gives
//     pdf(t) = D / ((theta_b - theta_a) (D^2 + (t - delta)^2)),
//     cdf(t) = (theta(t) - theta_a) / (theta_b - theta_a).
// tMax may be infinite (theta_b = pi / 2). Where x lies on the ray's line (D = 0) the density is
// a delta at delta; D is kept at least kMinRelativeDistance of the segment's scale instead, so
// every sample and density stays finite (a light inside the fog, on a camera ray).
#include "common/math/vec.h"

namespace lensfarm {

// The angles are in double: a segment far along the ray from a light near its line spans angles
// next to pi / 2, whose float spacing (1.2e-7) would quantise the samples and misstate their
// density (a bias, once weighted by MIS); double keeps both to 1e-16 of the angle.
struct EquiangularSegment {
  float tMin = 0.0f, tMax = 0.0f;
  double delta = 0.0;   // distance along the ray to the point nearest the light
  double d = 0.0;       // the ray's distance to the light, > 0
  double thetaA = 0.0;  // atan((tMin - delta) / d)
  double thetaB = 0.0;  // atan((tMax - delta) / d)
};

// The floor of D, relative to the segment's scale (max of |delta|, tMin and the finite tMax).
inline constexpr float kMinRelativeDistance = 1e-5f;

// The segment [tMin, tMax) of o + t dir (dir unit, tMin finite, tMin < tMax) seen from x.
EquiangularSegment equiangularSegment(const Vec3& o, const Vec3& dir, float tMin, float tMax, const Vec3& x);

// A distance in [tMin, tMax] from u in [0, 1), distributed as equiangularPdf.
float sampleEquiangular(const EquiangularSegment& s, float u);

// The density of sampleEquiangular at t (per unit distance); 0 outside [tMin, tMax].
float equiangularPdf(const EquiangularSegment& s, float t);

}  // namespace lensfarm
