#pragma once
// Unbiased transmittance estimators for a heterogeneous medium whose extinction sigma_t(t) along
// a ray is bounded by a majorant sigma_maj (PBR 4th ed. §14.2.3, pbrt-v4's SampleT_maj; Novák et
// al. 2018, "Monte Carlo Methods for Volumetric Light Transport Simulation", §3-4).
//
// Both draw tentative collisions as a homogeneous Poisson process of rate sigma_maj (exponential
// steps -ln(1 - u) / sigma_maj), which is what the majorant buys: no ray marching, no bias.
//  - Delta tracking (Woodcock et al. 1965): a tentative collision at t is real with probability
//    sigma_t(t) / sigma_maj; the first real one is a free-flight sample with density
//    sigma_t(t) T(t), and "no real collision before t1" has probability T(t1). As a transmittance
//    estimator it returns 0 or 1 (a boolean estimator: cheap, stops at the first real collision,
//    noisy).
//  - Ratio tracking (Cramer 1978; Novák, Selle & Jarosz 2014, "Residual Ratio Tracking"):
//    every tentative collision multiplies the estimate by 1 - sigma_t(t) / sigma_maj; its
//    expectation is T(t0, t1) = exp(-int sigma_t) and it never terminates early (lower variance,
//    the estimator for shadow rays).
// The majorant must satisfy sigma_t(t) <= sigma_maj on [t0, t1) (otherwise both are biased;
// ratio tracking's factor would go negative), and t1 must be finite where sigma_maj > 0 (ratio
// tracking walks to t1; GridMedium clips every piece to its box). A majorant of 0 means an empty piece: nothing is
// sampled there (the "empty space costs nothing" of a majorant grid, medium/grid_medium.h).
// Because the Poisson process is memoryless, a ray crossing several majorant cells is tracked
// piece by piece, restarting the exponential step at each piece: the result is the same process.
//
// Templates, not std::function: these loops run once per tentative collision inside the
// integrator, and the density lookup (a trilinear grid fetch) must inline into them; a
// std::function would add an indirect call and block inlining on every step. The callables are:
//   sigmaT(t) -> Value    extinction at distance t along the ray (Value: float or Spectrum)
//   uniform() -> float    a fresh uniform number in [0, 1) per call (the count varies per ray,
//                         so the integrator must key them by the ray, as pbrt-v4 hashes an RNG
//                         seed per ray, to stay deterministic across thread counts).
// Header only: all of it is these templates.
#include <cmath>

#include "common/math/vec.h"

namespace lensfarm {

// Delta tracking over [t0, t1) with majorant sigmaMaj: the first real collision's distance, or
// t1 when there is none (the boolean transmittance estimate is then 1).
template <typename SigmaT, typename Uniform>
float deltaTrack(float t0, float t1, float sigmaMaj, SigmaT&& sigmaT, Uniform&& uniform) {
  if (!(sigmaMaj > 0.0f)) return t1;
  float t = t0;
  for (;;) {
    t -= std::log1p(-uniform()) / sigmaMaj;
    if (!(t < t1)) return t1;
    if (uniform() * sigmaMaj < sigmaT(t)) return t;  // real collision, probability sigma_t / sigma_maj
  }
}

// Ratio tracking over [t0, t1): the product of (1 - sigma_t / sigma_maj) over tentative
// collisions, an unbiased estimate of exp(-int_t0^t1 sigma_t). Value is float or Spectrum.
template <typename Value, typename SigmaT, typename Uniform>
Value ratioTrack(float t0, float t1, float sigmaMaj, SigmaT&& sigmaT, Uniform&& uniform) {
  Value tr(1.0f);
  if (!(sigmaMaj > 0.0f)) return tr;
  float t = t0;
  for (;;) {
    t -= std::log1p(-uniform()) / sigmaMaj;
    if (!(t < t1)) return tr;
    tr *= Value(1.0f) - sigmaT(t) / sigmaMaj;
  }
}

// One majorant over the whole segment [0, d): transmittance estimates.
template <typename SigmaT, typename Uniform>
float deltaTrackingTransmittance(float d, float sigmaMaj, SigmaT&& sigmaT, Uniform&& uniform) {
  return deltaTrack(0.0f, d, sigmaMaj, sigmaT, uniform) < d ? 0.0f : 1.0f;
}
template <typename SigmaT, typename Uniform>
float ratioTrackingTransmittance(float d, float sigmaMaj, SigmaT&& sigmaT, Uniform&& uniform) {
  return ratioTrack<float>(0.0f, d, sigmaMaj, sigmaT, uniform);
}

}  // namespace lensfarm
