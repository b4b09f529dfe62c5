// Piecewise-constant distributions (math/distribution.h): densities proportional to the weights
// and integrating to 1, samples distributed by them (chi-square on cells and sub-cells,
// Kolmogorov-Smirnov on the continuous cdf), never in a cell of zero weight and never outside
// [0,1), the inverse, the uniform fallback, and tables too large for a float cdf.
#include "common/math/distribution.h"

#include <gtest/gtest.h>

#include "tests/support/uniform_rng.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace lensfarm {
namespace {

constexpr float kTop = 0x1.fffffep-1f;  // the largest float below 1

using Rng = test::UniformRng;

// The chi-square statistic of observed against expected counts as a standard normal deviate
// (Wilson-Hilferty): about N(0,1) for a correct sampler, so z < 4 fails a correct one with
// probability ~3e-5 (and the seeds are fixed); a wrong cell probability gives z in the hundreds.
double chiSquareZ(const std::vector<double>& observed, const std::vector<double>& expected) {
  double chi2 = 0.0;
  int dof = -1;
  for (size_t k = 0; k < observed.size(); ++k) {
    if (expected[k] <= 0.0) continue;
    chi2 += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
    ++dof;
  }
  const double k = double(dof), a = 2.0 / (9.0 * k);
  return (std::cbrt(chi2 / k) - (1.0 - a)) / std::sqrt(a);
}

std::vector<float> randomWeights(int n, uint32_t seed, double zeroFraction) {
  Rng rng(seed);
  std::vector<float> w(static_cast<size_t>(n));
  for (float& x : w) x = rng.next() < zeroFraction ? 0.0f : 0.05f + 3.0f * rng.next() * rng.next();
  return w;
}

// The exact cdf of the step function with these weights, in double, at x in [0,1].
double referenceCdf(const std::vector<float>& w, double x) {
  double total = 0.0, below = 0.0;
  for (float v : w) total += v;
  const double n = double(w.size());
  for (size_t i = 0; i < w.size(); ++i) {
    const double lo = double(i) / n, hi = double(i + 1) / n;
    if (x >= hi)
      below += w[i];
    else if (x > lo)
      below += w[i] * (x - lo) * n;
  }
  return below / total;
}

TEST(Distribution1D, DensityIsProportionalToTheWeightsAndIntegratesToOne) {
  const std::vector<float> w = {1.0f, 0.0f, 3.0f, 0.5f, 0.0f, 2.0f, 0.25f};
  const Distribution1D d(w);
  const double sum = 6.75, mean = sum / 7.0;
  EXPECT_EQ(d.size(), 7);
  EXPECT_FALSE(d.isUniformFallback());
  EXPECT_NEAR(d.integral(), mean, 1e-12) << "the integral over [0,1) is the mean weight";
  double pmfSum = 0.0, pdfIntegral = 0.0;
  for (int i = 0; i < 7; ++i) {
    EXPECT_NEAR(d.pmf(i), w[size_t(i)] / sum, 1e-7) << i;
    EXPECT_NEAR(d.pdf((float(i) + 0.5f) / 7.0f), w[size_t(i)] / mean, 1e-6) << i;
    pmfSum += d.pmf(i);
  }
  const int m = 70000;  // midpoint rule, 10000 points per cell: exact for a step function
  for (int k = 0; k < m; ++k) pdfIntegral += d.pdf(float((k + 0.5) / m)) / m;
  EXPECT_NEAR(pmfSum, 1.0, 1e-6);
  EXPECT_NEAR(pdfIntegral, 1.0, 1e-5);
  EXPECT_EQ(d.pdf(-0.1f), 0.0f);
  EXPECT_EQ(d.pdf(1.5f), 0.0f);
  EXPECT_EQ(d.pdf(std::nanf("")), 0.0f);
  EXPECT_EQ(d.pdf(1.0f), d.pdf(0.99f)) << "x == 1 belongs to the last cell";
  EXPECT_EQ(d.pmf(-1), 0.0f);
  EXPECT_EQ(d.pmf(7), 0.0f);
}

TEST(Distribution1D, SamplesFollowTheDensity) {
  const int n = 37, samples = 200000, sub = 4;
  const std::vector<float> w = randomWeights(n, 7, 0.2);
  const Distribution1D d(w);
  double total = 0.0;
  for (float v : w) total += v;
  // Chi-square over each cell cut into 4 sub-cells: tests both which cell is chosen and that
  // x is uniform inside it. Kolmogorov-Smirnov against the exact piecewise-linear cdf.
  std::vector<double> observed(size_t(n * sub), 0.0), expected(size_t(n * sub), 0.0);
  for (int i = 0; i < n; ++i)
    for (int s = 0; s < sub; ++s) expected[size_t(i * sub + s)] = samples * w[size_t(i)] / total / sub;
  std::vector<double> xs;
  xs.reserve(samples);
  Rng rng(11);
  for (int k = 0; k < samples; ++k) {
    float pdf = 0.0f;
    int offset = -1;
    const float x = d.sample(rng.next(), &pdf, &offset);
    ASSERT_TRUE(x >= 0.0f && x < 1.0f) << x;
    ASSERT_EQ(int(std::floor(double(x) * n)), offset) << "x lies in the cell reported";
    ASSERT_GT(w[size_t(offset)], 0.0f) << "a cell of zero weight was sampled";
    ASSERT_EQ(pdf, d.pdf(x)) << "the density reported is pdf(x), bit for bit";
    observed[size_t(std::min(int(std::floor(double(x) * n * sub)), n * sub - 1))] += 1.0;
    xs.push_back(x);
  }
  EXPECT_LT(chiSquareZ(observed, expected), 4.0);
  std::sort(xs.begin(), xs.end());
  double ks = 0.0;
  for (size_t k = 0; k < xs.size(); ++k) {
    const double f = referenceCdf(w, xs[k]);
    ks = std::max({ks, std::abs(f - double(k) / samples), std::abs(f - double(k + 1) / samples)});
  }
  EXPECT_LT(ks, 1.95 / std::sqrt(double(samples))) << "Kolmogorov-Smirnov at the 0.1 % level";
}

TEST(Distribution1D, CellsOfZeroWeightAreNeverSampled) {
  // Zero cells first, last and between; u swept finely and placed exactly on every cdf step.
  const std::vector<float> w = {0, 0, 5, 0, 0, 1, 0, 0, 0, 2, 0, 0};
  const int n = int(w.size());
  const Distribution1D d(w);
  std::vector<float> us = {0.0f, 0x1.0p-24f, kTop};
  for (int k = 0; k < (1 << 18); ++k) us.push_back(float(k) * 0x1.0p-18f);
  for (int i = 0; i <= n; ++i) {
    const float edge = d.invert(float(i) / float(n));
    us.push_back(edge);
    us.push_back(std::nextafter(edge, 0.0f));
    us.push_back(std::min(std::nextafter(edge, 1.0f), kTop));
  }
  for (const float u : us) {
    int offset = -1;
    const float x = d.sample(u, nullptr, &offset);
    ASSERT_GT(w[size_t(offset)], 0.0f) << "u = " << u;
    ASSERT_TRUE(x >= 0.0f && x < 1.0f) << "u = " << u;
    ASSERT_GT(d.pdf(x), 0.0f) << "u = " << u;
    float pmf = 0.0f, remapped = -1.0f;
    const int cell = d.sampleDiscrete(u, &pmf, &remapped);
    ASSERT_GT(w[size_t(cell)], 0.0f) << "u = " << u;
    ASSERT_EQ(cell, offset) << "discrete and continuous sampling choose the same cell";
    ASSERT_GT(pmf, 0.0f);
  }
  for (int i = 0; i < n; ++i)
    if (w[size_t(i)] == 0.0f) {
      EXPECT_EQ(d.pmf(i), 0.0f) << i;
      EXPECT_EQ(d.pdf((float(i) + 0.5f) / float(n)), 0.0f) << i;
    }
}

TEST(Distribution1D, SamplesStayInsideTheUnitIntervalAndTheirCell) {
  // x = (o + du) / n is computed in double and rounded to float. Where a cell is dense (density
  // above 2), du near 1 puts x within half a float ulp of the cell's upper edge, and x rounds
  // onto the next cell, or onto 1 from the last cell (weights {1, 1, 10}, u just below 1: in
  // double x = 1 - 2.4e-8, which rounds to 1). The sample must stay in its cell and below 1.
  const std::vector<float> badUs = {0.0f, 0x1.0p-24f, 0.5f,          kTop,     1.0f,
                                    2.0f, -1.0f,      std::nanf(""), INFINITY, -INFINITY};
  for (const int n : {1, 2, 3, 7, 1000, 4097, 1 << 20}) {
    const std::vector<float> flat(size_t(n), 1.0f);
    std::vector<float> dense = flat;
    dense.back() = 4.0f * float(n);  // the last cell holds ~80 % of the probability
    const std::vector<float> mixed = randomWeights(n, static_cast<uint32_t>(n), 0.1);
    const std::vector<float>* const tables[] = {&flat, &dense, &mixed};
    for (const std::vector<float>* w : tables) {
      const Distribution1D d(*w);
      std::vector<float> us = badUs;
      for (int i = 1; i <= std::min(n, 5000); ++i) {  // u just below every cdf step: du ~ 1
        const float edge = d.invert(float(i) / float(n));
        us.push_back(std::nextafter(edge, 0.0f));
        us.push_back(edge);
      }
      Rng rng(static_cast<uint32_t>(n));
      for (int k = 0; k < 5000; ++k) us.push_back(rng.next());
      for (const float u : us) {
        int offset = -1;
        float pdf = 0.0f;
        const float x = d.sample(u, &pdf, &offset);
        ASSERT_TRUE(x >= 0.0f && x < 1.0f) << "n " << n << " u " << u << " x " << x;
        ASSERT_EQ(int(std::floor(double(x) * n)), offset) << "n " << n << " u " << u;
        ASSERT_EQ(pdf, d.pdf(x)) << "n " << n << " u " << u;
        if (w == &flat) {
          ASSERT_NEAR(pdf, 1.0f, 1e-5f);
        }
      }
      int last = -1;
      EXPECT_LT(d.sample(kTop, nullptr, &last), 1.0f);
      if (w->back() > 0.0f) {
        EXPECT_EQ(last, n - 1) << "u just below 1 reaches the last cell";
      }
    }
  }
}

TEST(Distribution1D, AllZeroNegativeAndNaNWeightsFallBackToUniform) {
  for (const std::vector<float>& w : {std::vector<float>{0, 0, 0, 0}, std::vector<float>{},
                                      std::vector<float>{std::nanf(""), -1.0f, 0.0f, -INFINITY}}) {
    const Distribution1D d(w);
    EXPECT_TRUE(d.isUniformFallback());
    EXPECT_EQ(d.integral(), 0.0) << "the fallback still reports an integral of 0";
    for (const float u : {0.0f, 0.1f, 0.37f, 0.5f, 0.9f, kTop}) {
      float pdf = 0.0f;
      EXPECT_NEAR(d.sample(u, &pdf), u, 1e-6f);
      EXPECT_FLOAT_EQ(pdf, 1.0f);
      EXPECT_FLOAT_EQ(d.pdf(u), 1.0f);
    }
  }
  // NaN and negative weights count as 0 among positive ones; +inf as the largest float.
  const Distribution1D d(std::vector<float>{std::nanf(""), 2.0f, -1.0f, 2.0f});
  EXPECT_FALSE(d.isUniformFallback());
  EXPECT_DOUBLE_EQ(d.integral(), 1.0);
  EXPECT_EQ(d.pmf(0), 0.0f);
  EXPECT_EQ(d.pmf(2), 0.0f);
  EXPECT_FLOAT_EQ(d.pmf(1), 0.5f);
  EXPECT_FLOAT_EQ(d.pmf(3), 0.5f);
  const Distribution1D inf(std::vector<float>{1.0f, INFINITY});
  EXPECT_FLOAT_EQ(inf.pmf(1), 1.0f);
  EXPECT_GT(inf.pmf(0), 0.0f);
  EXPECT_TRUE(std::isfinite(inf.pdf(0.75f)));
  EXPECT_TRUE(std::isfinite(inf.integral()));
}

TEST(Distribution1D, InvertUndoesSample) {
  const std::vector<float> w = randomWeights(37, 3, 0.25);
  const Distribution1D d(w);
  EXPECT_EQ(d.invert(0.0f), 0.0f);
  EXPECT_EQ(d.invert(1.0f), 1.0f);
  float previous = -1.0f;
  for (int k = 0; k < 100000; ++k) {
    const float u = float(k) / 100000.0f;
    const float x = d.sample(u);
    ASSERT_NEAR(d.invert(x), u, 1e-6f) << "u " << u;
    ASSERT_GE(x, previous) << "sample() is monotone in u";
    previous = x;
  }
  for (int k = 0; k < 1000; ++k) {  // and sample(invert(x)) == x where the density is positive
    const float x = (float(k) + 0.5f) / 1000.0f;
    if (d.pdf(x) > 0.0f) {
      ASSERT_NEAR(d.sample(d.invert(x)), x, 2e-6f) << x;
    }
  }
}

TEST(Distribution1D, SampleDiscreteReturnsTheCellsProbabilityAndARemappedU) {
  const std::vector<float> w = randomWeights(19, 5, 0.2);
  const Distribution1D d(w);
  double total = 0.0;
  for (float v : w) total += v;
  std::vector<double> remappedSum(19, 0.0), hits(19, 0.0);
  const int m = 1 << 18;
  for (int k = 0; k < m; ++k) {
    const float u = float(k) / float(m);
    float pmf = 0.0f, remapped = -1.0f;
    const int cell = d.sampleDiscrete(u, &pmf, &remapped);
    ASSERT_NEAR(pmf, w[size_t(cell)] / total, 1e-7);
    ASSERT_EQ(pmf, d.pmf(cell));
    ASSERT_TRUE(remapped >= 0.0f && remapped < 1.0f);
    // u = cdf(cell) + remapped * pmf: the remapped value is where u fell inside the cell's share.
    ASSERT_NEAR(d.invert(float(cell) / 19.0f) + remapped * pmf, u, 2e-7f);
    remappedSum[size_t(cell)] += remapped;
    hits[size_t(cell)] += 1.0;
  }
  for (int i = 0; i < 19; ++i) {
    EXPECT_NEAR(hits[size_t(i)] / m, w[size_t(i)] / total, 1e-5) << i;
    if (hits[size_t(i)] > 100) {
      EXPECT_NEAR(remappedSum[size_t(i)] / hits[size_t(i)], 0.5, 0.01) << i;
    }
  }
}

TEST(Distribution1D, LargeTablesAccumulateTheirCdfInDouble) {
  // One cell of weight 2^24 followed by 2^20 cells of weight 1. In float, 2^24 + 1 == 2^24: a
  // float running sum never grows past the first cell, so every later cell would get no width
  // and never be sampled. In double each keeps its probability 1 / (2^24 + 2^20).
  const int tail = 1 << 20;
  std::vector<float> w(size_t(tail) + 1, 1.0f);
  w[0] = 0x1.0p24f;
  const Distribution1D d(w);
  const double total = 0x1.0p24 + double(tail);
  for (const int i : {1, 2, 1000, tail / 2, tail - 1, tail})
    EXPECT_NEAR(d.pmf(i), 1.0 / total, 1e-6 / total) << "cell " << i;
  EXPECT_NEAR(d.pmf(0), 0x1.0p24 / total, 1e-6);
  for (const int k : {0, 1, 12345, tail / 2, tail - 2}) {
    // u in the middle of tail cell k (offset 1 + k), given to float precision: as float, u
    // has a spacing of 2^-24 here, i.e. about 1.06 cells; round-to-nearest keeps it inside.
    const double uExact = (0x1.0p24 + double(k) + 0.5) / total;
    const float u = float(uExact);
    int offset = -1;
    float pdf = 0.0f;
    const float x = d.sample(u, &pdf, &offset);
    EXPECT_NEAR(double(offset), 1.0 + double(k), 1.0) << "k " << k;
    EXPECT_EQ(int(std::floor(double(x) * double(tail + 1))), offset);
    EXPECT_NEAR(pdf, double(tail + 1) / total, 1e-5);
  }
}

TEST(Distribution2D, SamplesFollowTheJointDensity) {
  const int nu = 9, nv = 6, samples = 200000;
  std::vector<float> w = randomWeights(nu * nv, 17, 0.15);
  for (int i = 0; i < nu; ++i) w[size_t(2 * nu + i)] = 0.0f;  // a whole row of zeros
  const Distribution2D d(w, nu, nv);
  double total = 0.0;
  for (float v : w) total += v;
  EXPECT_NEAR(d.integral(), total / (nu * nv), 1e-9) << "the integral over the square is the mean";
  EXPECT_EQ(d.width(), nu);
  EXPECT_EQ(d.height(), nv);

  // The density, integrated cell by cell (constant on each), sums to 1; it is w / mean.
  double integral = 0.0;
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      const float p = d.pdf(Vec2((float(u) + 0.5f) / float(nu), (float(v) + 0.5f) / float(nv)));
      EXPECT_NEAR(p, w[size_t(v * nu + u)] / (total / (nu * nv)), 1e-5) << u << ", " << v;
      integral += double(p) / (nu * nv);
    }
  EXPECT_NEAR(integral, 1.0, 1e-6);

  std::vector<double> observed(size_t(nu * nv), 0.0), expected(size_t(nu * nv));
  for (size_t k = 0; k < expected.size(); ++k) expected[k] = samples * w[k] / total;
  Rng rng(23);
  for (int k = 0; k < samples; ++k) {
    float pdf = 0.0f;
    glm::ivec2 cell(-1);
    const Vec2 uv = d.sample(rng.next2(), &pdf, &cell);
    ASSERT_TRUE(uv.x >= 0.0f && uv.x < 1.0f && uv.y >= 0.0f && uv.y < 1.0f);
    ASSERT_EQ(int(std::floor(double(uv.x) * nu)), cell.x);
    ASSERT_EQ(int(std::floor(double(uv.y) * nv)), cell.y);
    ASSERT_GT(w[size_t(cell.y * nu + cell.x)], 0.0f) << "a cell of zero weight was sampled";
    ASSERT_EQ(pdf, d.pdf(uv)) << "the density reported is pdf(uv), bit for bit";
    observed[size_t(cell.y * nu + cell.x)] += 1.0;
  }
  EXPECT_LT(chiSquareZ(observed, expected), 4.0);

  // Deterministic: the same weights and u give the same bits.
  const Distribution2D again(w, nu, nv);
  for (const Vec2 u : {Vec2(0.1f, 0.2f), Vec2(0.7f, 0.9f), Vec2(kTop, kTop), Vec2(0.0f, 0.0f)}) {
    float p0 = 0.0f, p1 = 0.0f;
    const Vec2 a = d.sample(u, &p0), b = again.sample(u, &p1);
    EXPECT_EQ(a, b);
    EXPECT_EQ(p0, p1);
  }
}

TEST(Distribution2D, AllZeroIsUniformAndABadShapeIsRefused) {
  const std::vector<float> zeros(12, 0.0f);
  const Distribution2D d(zeros, 4, 3);
  EXPECT_EQ(d.integral(), 0.0);
  for (const Vec2 u : {Vec2(0.1f, 0.2f), Vec2(0.7f, 0.9f), Vec2(kTop, 0.0f)}) {
    float pdf = 0.0f;
    const Vec2 uv = d.sample(u, &pdf);
    EXPECT_NEAR(uv.x, u.x, 1e-6f);
    EXPECT_NEAR(uv.y, u.y, 1e-6f);
    EXPECT_FLOAT_EQ(pdf, 1.0f);
  }
  EXPECT_THROW(Distribution2D(zeros, 5, 3), std::invalid_argument);
  EXPECT_THROW(Distribution2D(zeros, 0, 3), std::invalid_argument);
  EXPECT_EQ(d.pdf(Vec2(1.5f, 0.5f)), 0.0f);
  EXPECT_EQ(d.pdf(Vec2(0.5f, -0.5f)), 0.0f);
}

TEST(Distribution2D, AMapOf4096By2048ReachesItsLastRowAndColumn) {
  // An environment map's size: 2^23 cells. Weights vary by row and column; the corners of the
  // unit square reach the first and last cells, and every sample's density is pdf(uv).
  const int nu = 4096, nv = 2048;
  std::vector<float> w(size_t(nu) * nv);
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) w[size_t(v) * nu + u] = 1.0f + float((u * 7 + v * 13) % 101);
  const Distribution2D d(w, nu, nv);
  glm::ivec2 cell(-1);
  Vec2 uv = d.sample(Vec2(kTop, kTop), nullptr, &cell);
  EXPECT_EQ(cell, glm::ivec2(nu - 1, nv - 1));
  EXPECT_TRUE(uv.x < 1.0f && uv.y < 1.0f);
  uv = d.sample(Vec2(0.0f, 0.0f), nullptr, &cell);
  EXPECT_EQ(cell, glm::ivec2(0, 0));
  EXPECT_EQ(uv, Vec2(0.0f, 0.0f));
  double total = 0.0;
  for (float v : w) total += v;
  const double mean = total / (double(nu) * nv);
  Rng rng(29);
  for (int k = 0; k < 5000; ++k) {
    float pdf = 0.0f;
    uv = d.sample(rng.next2(), &pdf, &cell);
    ASSERT_EQ(pdf, d.pdf(uv));
    ASSERT_NEAR(pdf, w[size_t(cell.y) * nu + cell.x] / mean, 1e-4 * pdf);
  }
}

}  // namespace
}  // namespace lensfarm
