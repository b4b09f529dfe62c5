#pragma once
// A homogeneous participating medium (PBR 4th ed. §11.1, §11.4.1): constant absorption and
// scattering coefficients and a Henyey-Greenstein phase function (medium/phase_function.h).
//
// Units and conventions (docs/media.md repeats them for scene authors):
//  - sigma_a, sigma_s, sigma_t = sigma_a + sigma_s are per RGB channel, in 1 / scene units: light
//    travelling a distance d (scene units) keeps the fraction T(d) = exp(-sigma_t d) (Beer-Lambert).
//  - The single-scattering albedo is sigma_s / sigma_t (0 where sigma_t = 0).
//  - 0 * infinity is 0 here: no medium (sigma_t = 0) attenuates nothing even over an infinite
//    distance, and T is exactly 0 (never NaN) for sigma_t > 0 and d = infinity.
//
// glTF KHR_materials_volume: attenuationColor c (linear RGB in (0, 1]) is "the color that white
// light turns into due to absorption when reaching the attenuation distance" and
// attenuationDistance d (> 0, default +infinity) that distance, so T(d) = c, i.e.
//     sigma_t = -ln(c) / d   per channel.
// c = 1 or d = infinity give sigma_t = 0: no attenuation (the extension's default). The extension
// itself models absorption only (scattering is KHR_materials_volume_scatter's); fromAttenuation
// takes a scattering albedo besides (0 for a plain KHR volume): sigma_s = albedo sigma_t.
//
// Subsurface scattering (the random walk of material/subsurface.h): artists give the albedo A a
// thick slab should show (the multiple-scattering albedo) and a distance d per channel, not sigma_a and
// sigma_s. Chiang, Kutz & Burley 2016 ("Practical and Controllable Subsurface Scattering for
// Production Path Tracing", SIGGRAPH Talks; the mapping Cycles' random-walk SSS uses) fit, for an
// isotropic random walk in a semi-infinite index-matched medium,
//     single-scattering albedo  alpha = 1 - exp(-5.09406 A + 2.61188 A^2 - 4.31805 A^3)
//     extinction                sigma_t = 1 / (d s),   s = 1.9 - A + 3.5 (A - 0.8)^2
// so sigma_s = alpha sigma_t and sigma_a = (1 - alpha) sigma_t; sssCoefficients computes them.
// Against an independent half-space random walk (tests/medium, docs/media.md) the fit holds to
// 0.006 in A up to A = 0.8 and underestimates above (0.87 at A = 0.9, 0.92 at A = 0.99).
#include <string>

#include "common/math/vec.h"
#include "common/medium/phase_function.h"

namespace lensfarm {

// Beer-Lambert per channel, exp(-sigma_t d), with 0 * infinity = 0 (see above).
inline Spectrum beerLambert(const Spectrum& sigmaT, float d) {
  Spectrum t;
  for (int c = 0; c < 3; ++c) t[c] = sigmaT[c] > 0.0f ? std::exp(-sigmaT[c] * d) : 1.0f;
  return t;
}

// The outcome of sampling a free-flight distance along a segment of length tMax.
struct FreeFlight {
  bool scattered = false;  // true: a scattering event at distance t < tMax; false: passed the segment
  float t = 0.0f;
  // Throughput weight per channel: sigma_s T(t) / pbar(t) for an event, T(tMax) / Pbar for a pass
  // (see sampleFreeFlight); multiply the path throughput by it.
  Spectrum weight{0.0f};
};

class HomogeneousMedium {
 public:
  HomogeneousMedium(const Spectrum& sigmaA, const Spectrum& sigmaS, float g);
  // KHR_materials_volume's attenuation colour and distance (see above) and a scattering albedo.
  static HomogeneousMedium fromAttenuation(const Spectrum& attenuationColor, float attenuationDistance,
                                           const Spectrum& scatteringAlbedo, float g);

  const Spectrum& sigmaA() const { return sigmaA_; }
  const Spectrum& sigmaS() const { return sigmaS_; }
  const Spectrum& sigmaT() const { return sigmaT_; }
  const HenyeyGreenstein& phase() const { return phase_; }

  Spectrum transmittance(float d) const { return beerLambert(sigmaT_, d); }
  // pbar(t) = (1/3) sum_c sigma_c exp(-sigma_c t), the density of a scattering event at t of the
  // free-flight sampling below before any spectral history (a path's first segment): what the
  // volume tracer weighs equiangular sampling against (render/volume_integrator.cpp).
  float freeFlightDensity(float t) const;

  // Free-flight sampling for a chromatic medium with one-sample spectral MIS (the "hero channel"
  // of pbrt-v3's GridDensityMedium and Cycles' volume code): a channel c is chosen uniformly from
  // uChannel, t is drawn from p_c(t) = sigma_c exp(-sigma_c t) (t >= tMax: the segment is passed,
  // with probability P_c = exp(-sigma_c tMax)), and the sample is weighted with the average of the
  // three strategies (the balance heuristic for one sample, Veach 1997 §9.2.4):
  //     pbar(t) = (1/3) sum_c sigma_c exp(-sigma_c t),   Pbar = (1/3) sum_c exp(-sigma_c tMax).
  // Unbiasedness: for any f, E[weight f] over events is
  //     sum_c (1/3) int_0^tMax p_c(t) f(t) sigma_s T(t) / pbar(t) dt = int_0^tMax f(t) sigma_s T(t) dt,
  // because sum_c (1/3) p_c = pbar, valid wherever pbar > 0, i.e. wherever the integrand may be
  // non-zero (sigma_s[k] > 0 implies sigma_t[k] > 0 so p_k(t) > 0); likewise E[weight | pass]
  // P(pass) = T(tMax) since sum_c (1/3) P_c = Pbar. This is the volume rendering equation's split
  // into scattering inside the segment and transmission through it (PBR 4th ed. eq. 14.3). The
  // event weights are bounded: sigma_s,k T_k / pbar <= 3 sigma_s,k / sigma_t,k <= 3.
  // A channel with sigma_t = 0 (clear in that colour) never stops the ray; all-zero passes with
  // weight 1. tMax may be infinite.
  FreeFlight sampleFreeFlight(float tMax, float uChannel, float u) const;

  // The same with the channel fixed for a whole path (the hero channel, `hero`) and the balance
  // heuristic taken over the path's channel densities rather than each event's (hero-wavelength
  // spectral MIS, Wilkie et al. 2014; pbrt-v4's r_u): `ratio` holds p_c(path so far) / p(path so
  // far) up to a common factor, normalised to mean 1; each call multiplies it by this outcome's
  // p_c and returns weight f / mean_c(ratio_c p_c), f = sigma_s T(t) (event) or T(tMax) (pass).
  // The product of a path's weights is f(path) / mean_c p_c(path): at most 3 f / p_hero, so
  // however many events a path has, a channel whose own sampling would have weight 1 (albedo 1)
  // never weighs more than 3. Per event (ratio reset to 1 each time) weights are bounded too,
  // but their product over a long walk is heavy-tailed and under-estimates in practice (measured:
  // a chromatic albedo-1 sphere returned 0.91 of the light in its densest channel).
  // Start a path with ratio = 1 and a hero drawn uniformly from {0, 1, 2}.
  FreeFlight sampleFreeFlight(float tMax, int hero, float u, Spectrum& ratio) const;

 private:
  Spectrum sigmaA_, sigmaS_, sigmaT_;
  HenyeyGreenstein phase_;
};

struct SssCoefficients {
  Spectrum sigmaS, sigmaA;
};
// Chiang et al. 2016's inversion (see above), per channel: albedo A in [0, 1], distance d > 0.
SssCoefficients sssCoefficients(const Spectrum& albedo, const Spectrum& distance);
// The single-scattering albedo alpha(A) of that fit, for one channel.
float sssSingleScatteringAlbedo(float multipleScatteringAlbedo);

// The largest absorption or scattering coefficient a scene may give (1 / scene units).
inline constexpr float kMaxCoefficient = 1e30f;

// Validation for the scene loader: each throws one InputError(where, field + "...: ...").
// sigma_a, sigma_s: in [0, kMaxCoefficient] per channel; g in (-1, 1).
void validateHomogeneousMedium(const Spectrum& sigmaA, const Spectrum& sigmaS, float g, const std::string& where,
                               const std::string& field);
// attenuation_color in (0, 1] per channel, attenuation_distance > 0 (+infinity allowed), the
// scattering albedo in [0, 1], g in (-1, 1).
void validateAttenuation(const Spectrum& attenuationColor, float attenuationDistance, const Spectrum& scatteringAlbedo,
                         float g, const std::string& where, const std::string& field);
// SSS: albedo in [0, 1], distance finite and > 0 per channel.
void validateSss(const Spectrum& albedo, const Spectrum& distance, const std::string& where, const std::string& field);

}  // namespace lensfarm
