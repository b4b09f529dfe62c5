#pragma once
// A chi-squared goodness-of-fit test for direction samplers, in the manner of pbrt-v4's
// (src/pbrt/bsdfs_test.cpp) and Mitsuba 3's (python/mitsuba/chi2.py, ChiSquareTest):
// does a sampling routine produce directions distributed as its pdf says?
//
//  1. N directions are drawn from `sample` with a deterministic PCG32 stream (fixed seed: the
//     test is reproducible bit for bit) and binned on a theta x phi grid over the whole sphere.
//  2. The expected count of each cell is N times the integral of `pdf` over the cell, in
//     (theta, phi) with the Jacobian sin(theta), by adaptive Simpson cubature in double.
//  3. Cells are sorted by expected count; those expecting fewer than 5 samples are pooled into
//     one (the chi-squared approximation needs expected counts >= 5).
//  4. chi2 = sum (observed - expected)^2 / expected over the cells, with dof = cells - 1; the
//     p-value is the probability that a correct sampler scores chi2 or more: the regularised
//     upper incomplete gamma function Q(dof / 2, chi2 / 2).
//
// Absorbed samples (`sample` returns nothing) are simply not binned: `pdf` must then integrate to
// the fraction of samples not absorbed (a BSDF's sampling routine that sometimes fails, or whose
// lobe has albedo < 1), which Chi2Result reports as pdfIntegral and acceptedFraction.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "common/math/vec.h"

namespace lensfarm::test {

// PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
// Algorithms for Random Number Generation", pcg32 = XSH RR 64/32), as in pcg_basic.c.
class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed, uint64_t stream = 0xda3e39cb94b95bdbULL);
  uint32_t next();
  float uniform() { return float(next() >> 8) * 0x1p-24f; }  // in [0, 1), 24 bits

 private:
  uint64_t state_ = 0, inc_ = 0;
};

struct Chi2Options {
  int thetaBins = 40;  // over [0, pi]
  int phiBins = 0;     // over [0, 2 pi); 0: 2 * thetaBins
  uint64_t sampleCount = 1000000;
  uint64_t seed = 1;
  double minExpected = 5.0;  // cells expecting fewer samples are pooled
  // Cubature (Gauss-Legendre, 4 x 4 points per rectangle): each cell is split into 4^minDepth
  // rectangles first, then each rectangle is split while its estimate I and its quarters' differ
  // by more than
  //   max(relTolerance * I, statTolerance * sqrt(I / sampleCount), absTolerance * its share of
  //       the (theta, phi) rectangle [0, pi] x [0, 2 pi]),
  // to at most maxDepth levels: an expected count N I is then accurate to 1e-4 of itself or to
  // 0.5 % of its Poisson standard deviation sqrt(N I), whichever is looser, far below the noise
  // the statistic measures. Cells whose samples disagree with that are integrated again with
  // minDepth + refineDepth, at most maxRefinedCells of them, the worst first (see chi2Test).
  int minDepth = 1;
  int refineDepth = 3;
  int maxRefinedCells = 128;
  int maxDepth = 10;
  double relTolerance = 1e-4;
  double statTolerance = 5e-3;
  double absTolerance = 1e-7;
};

struct Chi2Result {
  double chi2 = 0.0;
  int dof = 0;
  double pValue = 0.0;                 // NaN when dof <= 0 (nothing to test): passes() rejects it
  double pdfIntegral = 0.0;            // the pdf integrated over the sphere
  double acceptedFraction = 0.0;       // samples not absorbed / sampleCount
  uint64_t invalidSamples = 0;         // non-finite or non-unit directions (forces pValue = 0)
  uint64_t invalidPdfValues = 0;       // negative or non-finite pdf values met (forces pValue = 0)
  uint64_t samplesWherePdfIsZero = 0;  // binned in cells whose pdf integral is 0 (forces pValue = 0)
  int pooledCells = 0;
  int refinedCells = 0;       // cells integrated a second time, finer (see Chi2Options)
  std::string histogramDump;  // summary, a residual map and the worst cells, for failures
};

// `sample(u, uLobe)`: a unit direction from u in [0,1)^2 (and uLobe in [0,1) to choose a lobe or
// to absorb), or nothing when the sample is absorbed. `pdf(w)`: its density in solid angle over
// the whole sphere.
using DirectionSampler = std::function<std::optional<Vec3>(Vec2 u, float uLobe)>;
using DirectionPdf = std::function<float(const Vec3& w)>;

Chi2Result chi2Test(const DirectionSampler& sample, const DirectionPdf& pdf, const Chi2Options& options = {});

// The regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a), a > 0, x >= 0:
// its series for x < a + 1 and Lentz's continued fraction otherwise (Numerical Recipes 3rd ed.
// §6.2), in double, relative accuracy ~1e-14; accurate in the far tail (tiny Q) as well.
double regularizedGammaQ(double a, double x);
// P(X >= chi2) for X chi-squared with dof degrees of freedom: Q(dof / 2, chi2 / 2).
double chi2PValue(double chi2, int dof);

// The Sidak-corrected significance level for one of testCount independent tests run at overall
// significance alpha: 1 - (1 - alpha)^(1 / testCount).
double sidakThreshold(double significance, int testCount);
// Whether a p-value passes: reject if p < 1 - (1 - significance)^(1 / testCount). NaN fails.
bool passes(double pValue, double significance, int testCount);

}  // namespace lensfarm::test
