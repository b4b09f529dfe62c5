#pragma once
// Warps from the unit square to the domains the renderer samples, with their densities.
// Each warp is a bijection, so stratified or low-discrepancy inputs keep their structure.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/math/vec.h"

namespace lensfarm {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = std::numbers::inv_pi_v<float>;

// The warps below are inline: they run several times per path, inside the integrator's loop.

// sin and cos of x in [-pi/4, pi/4] from their Taylor series to x^9 and x^10, whose next terms
// are below 2e-9 there: as accurate as float allows, without a library call (the library's
// sincosf was 3 % of render time; docs/performance.md).
inline void sinCosQuarterPi(float x, float& s, float& c) {
  const float x2 = x * x;
  s = x * (1.0f + x2 * (-1.0f / 6.0f + x2 * (1.0f / 120.0f + x2 * (-1.0f / 5040.0f + x2 * (1.0f / 362880.0f)))));
  c = 1.0f +
      x2 * (-0.5f + x2 * (1.0f / 24.0f + x2 * (-1.0f / 720.0f + x2 * (1.0f / 40320.0f + x2 * (-1.0f / 3628800.0f)))));
}

// Shirley-Chiu concentric map from [0,1)^2 to the unit disk; area-preserving, low distortion.
// The angle is (pi/4) o.y/o.x, or pi/2 - (pi/4) o.x/o.y, so only |x| <= pi/4 needs sin and cos.
inline Vec2 sampleConcentricDisk(Vec2 u) {
  const Vec2 o = 2.0f * u - Vec2(1.0f);
  if (o.x == 0.0f && o.y == 0.0f) return Vec2(0.0f);
  float s, c;
  if (std::abs(o.x) > std::abs(o.y)) {
    sinCosQuarterPi((kPi / 4.0f) * (o.y / o.x), s, c);
    return o.x * Vec2(c, s);
  }
  sinCosQuarterPi((kPi / 4.0f) * (o.x / o.y), s, c);  // cos(pi/2 - a) = sin a, sin(pi/2 - a) = cos a
  return o.y * Vec2(s, c);
}

// Cosine-weighted direction on the hemisphere around +z (Malley's method).
// pdf(w) = cos(theta) / pi. Replaces the 2013 report's rejection loop (§4.2) with an exact warp.
//
// Every u in [0,1)^2 gives a direction with z > 0 (so a positive pdf, and the estimator's weight
// f cos / pdf = albedo holds exactly). The rim of the square (u.x or u.y exactly 0) maps to the
// unit circle, where 1 - |d|^2 is 0 (or, by rounding, below): a horizon direction of pdf 0 that
// the integrator would drop, silently losing the sample. Such a sample instead leaves at height
// kRimHeight above the same point of the horizon, below the lowest direction an interior sample
// of 24-bit values reaches (z ~ 2^-11): a set of measure zero, so the estimate is unchanged, and
// every interior sample keeps its direction bit for bit (the scale there is exactly 1).
inline constexpr float kRimHeight = 0x1.0p-12f;
inline Vec3 sampleCosineHemisphere(Vec2 u) {
  const Vec2 d = sampleConcentricDisk(u);
  const float z = std::sqrt(std::max(0.0f, 1.0f - d.x * d.x - d.y * d.y));
  const bool rim = !(z > 0.0f);
  // sqrt(1 - kRimHeight^2) rounds to 1 in float: |(d, kRimHeight)| = 1 within float precision.
  return Vec3(d.x, d.y, rim ? kRimHeight : z);
}
inline float cosineHemispherePdf(float cosTheta) { return cosTheta > 0.0f ? cosTheta * kInvPi : 0.0f; }

// Uniform point on a triangle as barycentrics (b0, b1); b2 = 1 - b0 - b1. Heitz 2019 warp.
inline Vec2 sampleUniformTriangle(Vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2.0f;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2.0f;
    b0 = u.x - b1;
  }
  return Vec2(b0, b1);
}

// Veach's power heuristic (beta = 2) for two strategies with one sample each.
inline float powerHeuristic(float pdfA, float pdfB) {
  const float a = pdfA * pdfA, b = pdfB * pdfB;
  if (std::isinf(a)) return 1.0f;
  return a + b > 0.0f ? a / (a + b) : 0.0f;
}

}  // namespace lensfarm
