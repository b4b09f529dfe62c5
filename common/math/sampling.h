#pragma once
// Warps from the unit square to the domains the renderer samples, with their densities.
// Each warp is a bijection, so stratified or low-discrepancy inputs keep their structure.
#include <cmath>
#include <numbers>

#include "math/vec.h"

namespace lensfarm {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = std::numbers::inv_pi_v<float>;

// Shirley-Chiu concentric map from [0,1)^2 to the unit disk; area-preserving, low distortion.
Vec2 sampleConcentricDisk(Vec2 u);

// Cosine-weighted direction on the hemisphere around +z (Malley's method).
// pdf(w) = cos(theta) / pi. Replaces the seed's rejection loop (§4.2) with an exact warp.
Vec3 sampleCosineHemisphere(Vec2 u);
inline float cosineHemispherePdf(float cosTheta) { return cosTheta > 0.0f ? cosTheta * kInvPi : 0.0f; }

// Uniform point on a triangle as barycentrics (b0, b1); b2 = 1 - b0 - b1. Heitz 2019 warp.
Vec2 sampleUniformTriangle(Vec2 u);

// Veach's power heuristic (beta = 2) for two strategies with one sample each.
inline float powerHeuristic(float pdfA, float pdfB) {
  const float a = pdfA * pdfA, b = pdfB * pdfB;
  if (std::isinf(a)) return 1.0f;
  return a + b > 0.0f ? a / (a + b) : 0.0f;
}

}  // namespace lensfarm
