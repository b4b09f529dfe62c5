// Homogeneous media: Beer-Lambert transmittance, the chromatic free-flight estimator with spectral
// MIS, KHR_materials_volume's attenuation round trip, the SSS albedo inversion, validation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/medium/homogeneous_medium.h"
#include "common/util/error.h"
#include "tests/support/uniform_rng.h"

namespace lensfarm {
namespace {

TEST(HomogeneousMedium, TransmittanceIsBeerLambert) {
  const HomogeneousMedium m(Spectrum(0.1f, 1.0f, 0.0f), Spectrum(0.4f, 2.5f, 0.0f), 0.3f);
  EXPECT_EQ(m.sigmaT(), Spectrum(0.5f, 3.5f, 0.0f));
  for (const float d : {0.0f, 1e-4f, 0.37f, 2.0f, 10.0f}) {
    const Spectrum t = m.transmittance(d);
    EXPECT_NEAR(t.r, std::exp(-0.5 * d), 1e-3 * std::exp(-0.5 * d)) << d;
    EXPECT_NEAR(t.g, std::exp(-3.5 * d), 1e-3 * std::exp(-3.5 * d)) << d;
    EXPECT_EQ(t.b, 1.0f);
  }
  // Huge and infinite distances: 0 where the medium attenuates, 1 where it is clear, never NaN.
  for (const float d : {1e30f, INFINITY}) {
    const Spectrum t = m.transmittance(d);
    EXPECT_EQ(t, Spectrum(0.0f, 0.0f, 1.0f)) << d;
  }
}

// Runs the free-flight estimator n times over a segment of length d and checks, per channel and
// within 3 standard errors, that
//   E[weight; passed]           = exp(-sigma_t d),
//   E[weight; scattered]        = sigma_s / sigma_t (1 - exp(-sigma_t d)),
//   E[weight t; scattered]      = sigma_s (1 - exp(-sigma_t d) (1 + sigma_t d)) / sigma_t^2,
// the last of which tests the distribution of t, not only its total.
void checkFreeFlight(const HomogeneousMedium& m, float d, int n) {
  test::UniformRng rng(11);
  double sums[3][3] = {}, sq[3][3] = {};
  for (int i = 0; i < n; ++i) {
    const float uc = rng.next();
    const FreeFlight f = m.sampleFreeFlight(d, uc, rng.next());
    ASSERT_TRUE(isFinite(f.weight));
    ASSERT_TRUE(f.scattered ? f.t < d && f.t >= 0.0f : f.t == d);
    for (int c = 0; c < 3; ++c) {
      const double x[3] = {f.scattered ? 0.0 : f.weight[c], f.scattered ? f.weight[c] : 0.0,
                           f.scattered ? f.weight[c] * f.t : 0.0};
      for (int k = 0; k < 3; ++k) sums[k][c] += x[k], sq[k][c] += x[k] * x[k];
    }
  }
  for (int c = 0; c < 3; ++c) {
    const double st = m.sigmaT()[c], ss = m.sigmaS()[c], tr = std::exp(-st * d);
    const double expected[3] = {tr, st > 0 ? ss / st * (1 - tr) : 0.0,
                                st > 0 ? ss * (1 - tr * (1 + st * d)) / (st * st) : 0.0};
    for (int k = 0; k < 3; ++k) {
      const double mean = sums[k][c] / n, se = std::sqrt(std::max(0.0, sq[k][c] / n - mean * mean) / n);
      EXPECT_NEAR(mean, expected[k], 3 * se + 1e-7) << "channel " << c << " estimator " << k;
    }
  }
}

TEST(HomogeneousMedium, ChromaticFreeFlightIsUnbiasedPerChannel) {
  // Very different sigma_t per channel, one of them 0 (clear in blue).
  checkFreeFlight(HomogeneousMedium(Spectrum(0.2f, 0.5f, 0.0f), Spectrum(0.3f, 3.0f, 0.0f), 0.0f), 1.3f, 400000);
  // Scattering in a channel whose neighbours are thick, over a thin and a thick segment.
  checkFreeFlight(HomogeneousMedium(Spectrum(4.0f, 0.0f, 0.05f), Spectrum(1.0f, 0.01f, 0.9f), 0.5f), 0.2f, 400000);
  checkFreeFlight(HomogeneousMedium(Spectrum(4.0f, 0.0f, 0.05f), Spectrum(1.0f, 0.01f, 0.9f), 0.5f), 5.0f, 400000);
}

TEST(HomogeneousMedium, FreeFlightWeightsAreBounded) {
  // sigma_s T / pbar <= 3 sigma_s / sigma_t: no fireflies from the spectral MIS.
  const HomogeneousMedium m(Spectrum(0.0f, 0.0f, 0.0f), Spectrum(0.01f, 1.0f, 50.0f), 0.0f);
  test::UniformRng rng(5);
  for (int i = 0; i < 100000; ++i) {
    const float uc = rng.next();
    const FreeFlight f = m.sampleFreeFlight(INFINITY, uc, rng.next());
    ASSERT_TRUE(f.scattered);  // an infinite segment of a medium scattering in every channel
    for (int c = 0; c < 3; ++c) ASSERT_LE(f.weight[c], 3.0f + 1e-5f);
  }
  // A medium clear in every channel: always passes with weight 1, even over an infinite segment.
  const HomogeneousMedium clear(Spectrum(0.0f), Spectrum(0.0f), 0.0f);
  const FreeFlight f = clear.sampleFreeFlight(INFINITY, 0.5f, 0.5f);
  EXPECT_FALSE(f.scattered);
  EXPECT_EQ(f.weight, Spectrum(1.0f));
}

TEST(HomogeneousMedium, KhrAttenuationRoundTrips) {
  // T at the attenuation distance is the attenuation colour.
  const Spectrum color(0.2f, 0.55f, 1.0f);
  for (const float d : {0.01f, 2.5f, 300.0f}) {
    const HomogeneousMedium m = HomogeneousMedium::fromAttenuation(color, d, Spectrum(0.0f), 0.0f);
    const Spectrum t = m.transmittance(d);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(t[c], color[c], 1e-5f * color[c]) << d;
    EXPECT_EQ(m.sigmaS(), Spectrum(0.0f));  // KHR_materials_volume alone absorbs only
  }
  // Infinite distance (the extension's default): no attenuation at all.
  EXPECT_EQ(HomogeneousMedium::fromAttenuation(color, INFINITY, Spectrum(0.5f), 0.0f).sigmaT(), Spectrum(0.0f));
  // A scattering albedo splits sigma_t without changing it.
  const HomogeneousMedium s = HomogeneousMedium::fromAttenuation(color, 2.0f, Spectrum(0.25f, 0.5f, 1.0f), 0.0f);
  const float st = -std::log(0.2f) / 2.0f;
  EXPECT_NEAR(s.sigmaS().r, 0.25f * st, 1e-6f);
  EXPECT_NEAR(s.sigmaA().r, 0.75f * st, 1e-6f);
  EXPECT_NEAR(s.transmittance(2.0f).g, 0.55f, 1e-6f);
}

// The fraction of light entering a semi-infinite, index-matched, isotropically scattering medium
// with diffuse (cosine-distributed) incidence that comes back out: an analog random walk in
// double, independent of the code under test.
double halfSpaceAlbedo(double alpha, int walks, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int escaped = 0;
  for (int i = 0; i < walks; ++i) {
    double z = 0.0, dz = -std::sqrt(u(rng));  // inward, cosine-weighted
    for (;;) {
      z -= std::log(1.0 - u(rng)) * dz;
      if (z > 0.0) {
        ++escaped;
        break;
      }
      if (u(rng) >= alpha) break;  // absorbed
      dz = 1.0 - 2.0 * u(rng);     // isotropic
    }
  }
  return double(escaped) / walks;
}

TEST(SssCoefficients, TheInvertedAlbedoReproducesTheMultipleScatteringAlbedo) {
  // Chiang et al. 2016's fit: the single-scattering albedo alpha(A) makes a thick slab show A.
  // Measured with this random walk (200k walks): within 0.006 for A <= 0.8; the fit drifts above
  // that (0.872 at A = 0.9, 0.92 at A = 0.99; docs/media.md), so those are not asserted.
  for (const float a : {0.1f, 0.3f, 0.5f, 0.8f}) {
    const double alpha = sssSingleScatteringAlbedo(a);
    EXPECT_NEAR(halfSpaceAlbedo(alpha, 60000, 9), a, 0.015) << "A = " << a << " alpha = " << alpha;
  }
  // The published polynomial at hand-computed points.
  EXPECT_NEAR(sssSingleScatteringAlbedo(0.5f), 1.0 - std::exp(-0.5 * 5.09406 + 0.25 * 2.61188 - 0.125 * 4.31805), 1e-6);
  EXPECT_EQ(sssSingleScatteringAlbedo(0.0f), 0.0f);
  // sigma_t = 1 / (d s), s = 1.9 - A + 3.5 (A - 0.8)^2: s = 1.1 at A = 0.8, 1.9 + 3.5 * 0.64 at 0.
  const SssCoefficients k = sssCoefficients(Spectrum(0.8f, 0.0f, 0.5f), Spectrum(2.0f, 1.0f, 0.1f));
  EXPECT_NEAR(k.sigmaS.r + k.sigmaA.r, 1.0 / (2.0 * 1.1), 1e-6);
  EXPECT_NEAR(k.sigmaS.g + k.sigmaA.g, 1.0 / (1.9 + 3.5 * 0.64), 1e-6);
  EXPECT_NEAR(k.sigmaS.b + k.sigmaA.b, 1.0 / (0.1 * (1.9 - 0.5 + 3.5 * 0.09)), 1e-5);
  EXPECT_NEAR(k.sigmaS.r / (k.sigmaS.r + k.sigmaA.r), sssSingleScatteringAlbedo(0.8f), 1e-6);
  EXPECT_EQ(k.sigmaS.g, 0.0f);
}

// Calls f, expects exactly one InputError whose message names `field`.
template <typename F>
void expectFieldError(F f, const std::string& field) {
  try {
    f();
    ADD_FAILURE() << "no error for " << field;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "scene.json");
    EXPECT_NE(std::string(e.what()).find(field + ":"), std::string::npos) << e.what();
  }
}

TEST(HomogeneousMedium, BadInputNamesTheField) {
  const Spectrum ok(0.5f);
  const std::string f = "media[2]";
  const auto homogeneous = [&](Spectrum a, Spectrum s, float g) {
    return [=] { validateHomogeneousMedium(a, s, g, "scene.json", f); };
  };
  expectFieldError(homogeneous(Spectrum(-0.1f, 0.5f, 0.5f), ok, 0.0f), f + ".sigma_a");
  expectFieldError(homogeneous(Spectrum(NAN), ok, 0.0f), f + ".sigma_a");
  expectFieldError(homogeneous(ok, Spectrum(0.1f, INFINITY, 0.1f), 0.0f), f + ".sigma_s");
  expectFieldError(homogeneous(ok, Spectrum(0.1f, 0.1f, -1.0f), 0.0f), f + ".sigma_s");
  expectFieldError(homogeneous(ok, ok, 1.0f), f + ".g");
  expectFieldError(homogeneous(ok, ok, -1.2f), f + ".g");
  EXPECT_NO_THROW(homogeneous(Spectrum(0.0f), ok, 0.9f)());

  const auto khr = [&](Spectrum c, float d, Spectrum albedo) {
    return [=] { validateAttenuation(c, d, albedo, 0.0f, "scene.json", f); };
  };
  expectFieldError(khr(Spectrum(0.0f, 0.5f, 0.5f), 1.0f, ok), f + ".attenuation_color");
  expectFieldError(khr(Spectrum(1.1f, 0.5f, 0.5f), 1.0f, ok), f + ".attenuation_color");
  expectFieldError(khr(ok, 0.0f, ok), f + ".attenuation_distance");
  expectFieldError(khr(ok, -2.0f, ok), f + ".attenuation_distance");
  expectFieldError(khr(ok, NAN, ok), f + ".attenuation_distance");
  expectFieldError(khr(ok, 1.0f, Spectrum(1.5f)), f + ".scattering_albedo");
  EXPECT_NO_THROW(khr(Spectrum(1.0f), INFINITY, Spectrum(0.0f))());

  expectFieldError([&] { validateSss(Spectrum(1.2f), ok, "scene.json", f); }, f + ".albedo");
  expectFieldError([&] { validateSss(ok, Spectrum(0.0f), "scene.json", f); }, f + ".mean_free_path");
  expectFieldError([&] { validateSss(ok, Spectrum(INFINITY), "scene.json", f); }, f + ".mean_free_path");
  EXPECT_NO_THROW(validateSss(ok, ok, "scene.json", f));
}

}  // namespace
}  // namespace lensfarm
