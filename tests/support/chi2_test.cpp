// The chi-squared harness (tests/support/chi2.h) checked on itself: its p-values against closed
// forms of the incomplete gamma function, and its power: it accepts correct samplers and rejects
// a sampler whose pdf is wrong, including a wrong account of absorbed samples.
#include "tests/support/chi2.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/math/sampling.h"

namespace lensfarm::test {
namespace {

Chi2Options smallRun() {
  Chi2Options o;
  o.thetaBins = 20;
  o.sampleCount = 200000;
  return o;
}

DirectionSampler cosineSampler() {
  return [](Vec2 u, float) { return std::optional<Vec3>(sampleCosineHemisphere(u)); };
}
DirectionPdf cosinePdf() {
  return [](const Vec3& w) { return cosineHemispherePdf(w.z); };
}

// ln(sum_{k<n} x^k / k!) by log-sum-exp: Q(n, x) = e^-x sum_{k<n} x^k / k! for integer n.
double logPoissonSum(int n, double x) {
  double best = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < n; ++k) best = std::max(best, k * std::log(x) - std::lgamma(k + 1.0));
  double s = 0.0;
  for (int k = 0; k < n; ++k) s += std::exp(k * std::log(x) - std::lgamma(k + 1.0) - best);
  return best + std::log(s);
}

TEST(Chi2Math, UpperIncompleteGammaMatchesClosedForms) {
  for (double x : {1e-6, 0.01, 0.3, 1.0, 2.5, 7.0, 30.0, 200.0}) {
    EXPECT_NEAR(regularizedGammaQ(1.0, x) / std::exp(-x), 1.0, 1e-12) << x;             // Q(1, x) = e^-x
    EXPECT_NEAR(regularizedGammaQ(0.5, x) / std::erfc(std::sqrt(x)), 1.0, 1e-10) << x;  // Q(1/2, x) = erfc(sqrt x)
    EXPECT_NEAR(chi2PValue(2.0 * x, 2) / std::exp(-x), 1.0, 1e-12) << x;                // chi2 with 2 dof
  }
  // Integer a: the Poisson sum, in both branches (series below a + 1, continued fraction above)
  // and far in the tail, to relative accuracy.
  for (int n : {3, 10, 50, 400})
    for (double x : {0.5 * n, 0.9 * n, 1.0 * n + 2.0, 1.5 * n, 3.0 * n + 30.0}) {
      const double exact = std::exp(-x + logPoissonSum(n, x));
      EXPECT_NEAR(regularizedGammaQ(n, x) / exact, 1.0, 1e-9) << "a " << n << " x " << x;
    }
  // The median of Gamma(a) is a - 1/3 + O(1/a): for the dof of a real run, Q is 1/2 there.
  EXPECT_NEAR(regularizedGammaQ(1600.0, 1600.0 - 1.0 / 3.0), 0.5, 1e-4);
  EXPECT_EQ(regularizedGammaQ(3.0, 0.0), 1.0);
  EXPECT_TRUE(std::isnan(regularizedGammaQ(0.0, 1.0)));
}

TEST(Chi2Math, SidakCorrectionLowersTheThresholdPerTest) {
  EXPECT_NEAR(sidakThreshold(0.01, 1), 0.01, 1e-15);
  EXPECT_NEAR(sidakThreshold(0.01, 25), 1.0 - std::pow(0.99, 1.0 / 25.0), 1e-15);  // 4.02e-4
  EXPECT_TRUE(passes(5e-4, 0.01, 25));
  EXPECT_FALSE(passes(3e-4, 0.01, 25));
  EXPECT_FALSE(passes(std::numeric_limits<double>::quiet_NaN(), 0.01, 1));
}

TEST(Chi2Harness, AcceptsACorrectSampler) {
  const Chi2Result r = chi2Test(cosineSampler(), cosinePdf(), smallRun());
  EXPECT_TRUE(passes(r.pValue, 0.01, 1)) << r.histogramDump;
  EXPECT_NEAR(r.pdfIntegral, 1.0, 1e-6);
  EXPECT_EQ(r.acceptedFraction, 1.0);
  EXPECT_GT(r.dof, 300) << "the cells of the upper hemisphere are tested, not pooled";
  // Few samples: the cells near the pole and the horizon expect fewer than 5 and are pooled.
  Chi2Options few = smallRun();
  few.sampleCount = 5000;
  const Chi2Result pooled = chi2Test(cosineSampler(), cosinePdf(), few);
  EXPECT_TRUE(passes(pooled.pValue, 0.01, 1)) << pooled.histogramDump;
  EXPECT_GT(pooled.pooledCells, 40);
  EXPECT_LT(pooled.dof, 400 - 40);
}

// Uniform directions on the sphere: on a 10 x 20 grid every cell expects >= 5 of 20000 samples, so
// none is pooled and dof = 199; and over 32 seeds the p-values of this correct sampler are
// uniform on [0, 1] (Kolmogorov-Smirnov at 1 %: D < 1.63 / sqrt(32)), which they are only with
// the right statistic, dof and incomplete gamma function.
TEST(Chi2Harness, PValuesOfACorrectSamplerAreUniform) {
  const DirectionSampler uniformSphere = [](Vec2 u, float) {
    const float z = 1.0f - 2.0f * u.x, r = std::sqrt(std::max(0.0f, 1.0f - z * z)), phi = 2.0f * kPi * u.y;
    return std::optional<Vec3>(Vec3(r * std::cos(phi), r * std::sin(phi), z));
  };
  const DirectionPdf uniformPdf = [](const Vec3&) { return 0.25f * kInvPi; };
  std::vector<double> p;
  for (uint64_t seed = 1; seed <= 32; ++seed) {
    Chi2Options o;
    o.thetaBins = 10;
    o.sampleCount = 20000;
    o.seed = seed;
    const Chi2Result r = chi2Test(uniformSphere, uniformPdf, o);
    EXPECT_EQ(r.dof, 199);
    EXPECT_EQ(r.pooledCells, 0);
    p.push_back(r.pValue);
  }
  std::sort(p.begin(), p.end());
  double d = 0.0;
  for (size_t k = 0; k < p.size(); ++k)
    d = std::max({d, p[k] - double(k) / double(p.size()), double(k + 1) / double(p.size()) - p[k]});
  EXPECT_LT(d, 1.63 / std::sqrt(32.0));
}

TEST(Chi2Harness, RejectsCosineSamplesAgainstAUniformPdf) {
  const DirectionPdf uniformHemisphere = [](const Vec3& w) { return w.z > 0.0f ? 0.5f * kInvPi : 0.0f; };
  const Chi2Result r = chi2Test(cosineSampler(), uniformHemisphere, smallRun());
  EXPECT_LT(r.pValue, 1e-12) << r.histogramDump;
  EXPECT_NEAR(r.pdfIntegral, 1.0, 1e-6) << "both are normalised: only the shape is wrong";
  // A subtler error: a cosine-power lobe (n + 1) / (2 pi) cos^n with n = 1.05 instead of 1.
  const DirectionPdf cosinePower = [](const Vec3& w) {
    return w.z > 0.0f ? float(2.05 / (2.0 * M_PI) * std::pow(double(w.z), 1.05)) : 0.0f;
  };
  Chi2Options o = smallRun();
  o.sampleCount = 1000000;
  const Chi2Result subtle = chi2Test(cosineSampler(), cosinePower, o);
  EXPECT_LT(subtle.pValue, 1e-6) << subtle.histogramDump;
}

TEST(Chi2Harness, AbsorbedSamplesNeedAPdfThatIntegratesToTheAcceptedFraction) {
  // 30 % of the samples are absorbed; the lobe's pdf integrates to 0.7.
  const DirectionSampler absorbing = [](Vec2 u, float uLobe) -> std::optional<Vec3> {
    if (uLobe < 0.3f) return std::nullopt;
    return sampleCosineHemisphere(u);
  };
  const Chi2Result ok = chi2Test(
      absorbing, [](const Vec3& w) { return 0.7f * cosineHemispherePdf(w.z); }, smallRun());
  EXPECT_TRUE(passes(ok.pValue, 0.01, 2)) << ok.histogramDump;
  EXPECT_NEAR(ok.pdfIntegral, 0.7, 1e-6);
  EXPECT_NEAR(ok.acceptedFraction, 0.7, 5e-3);
  // The pdf of the unabsorbed lobe alone, normalised to 1, claims 43 % too many samples.
  const Chi2Result wrong = chi2Test(absorbing, cosinePdf(), smallRun());
  EXPECT_LT(wrong.pValue, 1e-12);
  EXPECT_NEAR(wrong.pdfIntegral, 1.0, 1e-6);
}

TEST(Chi2Harness, FlagsBrokenSamplesAndPdfs) {
  const Chi2Result notUnit = chi2Test(
      [](Vec2 u, float) { return std::optional<Vec3>(2.0f * sampleCosineHemisphere(u)); }, cosinePdf(), smallRun());
  EXPECT_EQ(notUnit.pValue, 0.0);
  EXPECT_EQ(notUnit.invalidSamples, 200000u) << notUnit.histogramDump;
  // Samples below the surface, where the pdf says nothing can go.
  const Chi2Result below =
      chi2Test([](Vec2 u, float) { return std::optional<Vec3>(-sampleCosineHemisphere(u)); }, cosinePdf(), smallRun());
  EXPECT_EQ(below.pValue, 0.0);
  EXPECT_GT(below.samplesWherePdfIsZero, 0u) << below.histogramDump;
  const Chi2Result nanPdf = chi2Test(
      cosineSampler(), [](const Vec3&) { return std::nanf(""); }, smallRun());
  EXPECT_EQ(nanPdf.pValue, 0.0);
  EXPECT_GT(nanPdf.invalidPdfValues, 0u);
}

}  // namespace
}  // namespace lensfarm::test
