// Equiangular distance sampling (medium/equiangular.h): its density integrates to 1 over the
// segment (Simpson's rule, in double), its samples follow the closed-form cdf (a chi-squared test
// over 64 equal-probability bins), and a light on the ray's line or an unbounded segment
// keeps every sample and density finite, at any scene scale.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/medium/equiangular.h"
#include "tests/support/chi2.h"

namespace lensfarm {
namespace {

// The integral of the density over [a, b], by composite Simpson's rule on n intervals in t.
double integratePdf(const EquiangularSegment& s, double a, double b, int n = 200000) {
  const double h = (b - a) / n;
  double sum = double(equiangularPdf(s, float(a))) + double(equiangularPdf(s, float(b)));
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * double(equiangularPdf(s, float(a + i * h)));
  return sum * h / 3.0;
}

TEST(Equiangular, TheDensityIntegratesToOneOverTheSegment) {
  // A light 0.3 off the ray, 2 along it, over [0.5, 6]: the peak of 1 / r^2 inside the segment.
  const EquiangularSegment s = equiangularSegment(Vec3(0.0f), Vec3(1, 0, 0), 0.5f, 6.0f, Vec3(2.0f, 0.3f, 0.0f));
  EXPECT_NEAR(s.delta, 2.0, 1e-6);
  EXPECT_NEAR(s.d, 0.3, 1e-6);
  EXPECT_NEAR(integratePdf(s, 0.5, 6.0), 1.0, 1e-5);
  EXPECT_EQ(equiangularPdf(s, 0.49f), 0.0f);
  EXPECT_EQ(equiangularPdf(s, 6.01f), 0.0f);
  // The density is proportional to 1 / r^2: its ratio between two points is the inverse ratio
  // of their squared distances to the light.
  const float r1 = 0.3f * 0.3f + 1.0f, r2 = 0.3f * 0.3f + 9.0f;  // t = 3 and t = 5
  EXPECT_NEAR(equiangularPdf(s, 3.0f) / equiangularPdf(s, 5.0f), r2 / r1, 1e-5);
}

// 64 bins of equal probability by the cdf (theta uniform): bin k ends at delta + d tan(theta_k).
constexpr int kBins = 64;
std::vector<double> equalProbabilityEdges(const EquiangularSegment& s) {
  std::vector<double> edges(kBins + 1);
  for (int k = 0; k <= kBins; ++k)
    edges[size_t(k)] = s.delta + s.d * std::tan(s.thetaA + (s.thetaB - s.thetaA) * k / kBins);
  return edges;
}

// Pearson's chi-squared statistic of 640,000 samples over the equal-probability bins.
double chiSquaredOfSamples(const EquiangularSegment& s) {
  const std::vector<double> edges = equalProbabilityEdges(s);
  test::Pcg32 rng(7);
  constexpr int kSamples = 640000;
  std::vector<double> counts(kBins, 0.0);
  for (int i = 0; i < kSamples; ++i) {
    const double t = sampleEquiangular(s, rng.uniform());
    EXPECT_TRUE(t >= s.tMin && t <= s.tMax) << t;
    const auto bin = std::upper_bound(edges.begin(), edges.end(), t) - edges.begin() - 1;
    counts[size_t(std::clamp<long>(bin, 0, kBins - 1))] += 1.0;
  }
  double chi2 = 0.0;
  const double expected = double(kSamples) / kBins;
  for (double c : counts) chi2 += (c - expected) * (c - expected) / expected;
  return chi2;
}

TEST(Equiangular, SamplesFollowTheClosedFormCdf) {
  const EquiangularSegment s =
      equiangularSegment(Vec3(1, 2, 3), glm::normalize(Vec3(1, 1, 0)), 0.0f, 10.0f, Vec3(4.0f, 3.0f, 3.5f));
  // Each bin's probability by integrating the density: 1 / kBins (the density and cdf agree).
  const std::vector<double> edges = equalProbabilityEdges(s);
  for (int k = 0; k < kBins; k += 9)
    EXPECT_NEAR(integratePdf(s, edges[size_t(k)], edges[size_t(k) + 1], 20000), 1.0 / kBins, 1e-5) << k;
  // 63 degrees of freedom: chi2 above 110 has a probability below 1e-4 for a correct sampler.
  EXPECT_LT(chiSquaredOfSamples(s), 110.0);
}

TEST(Equiangular, ASegmentFarAlongTheRayFromALightNearItsLineKeepsItsDensity) {
  // A light 1e-3 off the ray's line, the segment [10, 11] beyond it: angles within 1e-4 of pi / 2,
  // which float would step in 1.2e-7 (about 76 distinct samples): the samples still follow the
  // density, which still integrates to 1.
  const EquiangularSegment s = equiangularSegment(Vec3(0.0f), Vec3(0, 0, 1), 10.0f, 11.0f, Vec3(1e-3f, 0.0f, 0.0f));
  EXPECT_NEAR(integratePdf(s, 10.0, 11.0), 1.0, 1e-5);
  EXPECT_LT(chiSquaredOfSamples(s), 110.0);
}

TEST(Equiangular, ALightOnTheRayAnUnboundedSegmentAndAnyScaleStayFinite) {
  // The light on the ray's line (a camera ray through a light inside fog): D is floored.
  const EquiangularSegment on = equiangularSegment(Vec3(0.0f), Vec3(0, 0, 1), 0.0f, 4.0f, Vec3(0, 0, 2));
  EXPECT_GT(on.d, 0.0f);
  for (float u : {0.0f, 0.25f, 0.5f, 0.75f, 0.999999f}) {
    const float t = sampleEquiangular(on, u);
    EXPECT_TRUE(t >= 0.0f && t <= 4.0f) << u;
    EXPECT_TRUE(std::isfinite(equiangularPdf(on, t))) << u;
  }
  // An unbounded segment (no surface behind the fog).
  const EquiangularSegment open = equiangularSegment(Vec3(0.0f), Vec3(1, 0, 0), 0.0f, INFINITY, Vec3(3, 1, 0));
  EXPECT_NEAR(integratePdf(open, 0.0, 1e5, 2000000),
              1.0 - (M_PI / 2 - std::atan((1e5 - 3.0) / 1.0)) / (M_PI / 2 - std::atan(-3.0)), 1e-4);
  EXPECT_TRUE(std::isfinite(sampleEquiangular(open, 0.9999999f)));
  // Scenes at 1e-4 and 1e4 scale (render space is centred on the camera, scene/scene.h, so a
  // scene far from the origin reaches here as one near it): the same density, scaled.
  for (const float scale : {1e-4f, 1e4f}) {
    const EquiangularSegment s =
        equiangularSegment(Vec3(0.0f), Vec3(0, 1, 0), 0.0f, 4.0f * scale, Vec3(1.0f, 2.0f, 0.0f) * scale);
    EXPECT_NEAR(integratePdf(s, 0.0, 4.0 * scale), 1.0, 1e-4) << scale;
    EXPECT_NEAR(equiangularPdf(s, 2.0f * scale) * scale, 1.0f / (2.0f * std::atan(2.0f)), 1e-5f) << scale;
  }
}

}  // namespace
}  // namespace lensfarm
