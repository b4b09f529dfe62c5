// Heterogeneous media: the majorant grid bounds the density, the DDA visits exactly the majorant
// cells a segment crosses, delta and ratio tracking agree with each other and with the analytic
// (or finely integrated) optical depth, empty space costs no random numbers, validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "common/medium/grid_medium.h"
#include "common/util/error.h"
#include "tests/support/uniform_rng.h"

namespace lensfarm {
namespace {

std::vector<float> randomDensities(const glm::ivec3& res, uint32_t seed, float emptyFraction) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> d(size_t(res.x * res.y * res.z));
  for (float& v : d) v = u(rng) < emptyFraction ? 0.0f : 2.0f * u(rng);
  return d;
}

struct Piece {
  glm::ivec3 cell;
  double t0, t1;
};

// Every majorant cell whose box the ray o + t dir meets over t in [0, tMax] for a length above
// eps, found by a slab test against each cell in double, in order of entry.
std::vector<Piece> bruteForceCells(const GridMedium& m, const Vec3& o, const Vec3& dir, float tMax, double eps) {
  std::vector<Piece> out;
  const glm::ivec3 r = m.majorantResolution();
  for (int k = 0; k < r.z; ++k)
    for (int j = 0; j < r.y; ++j)
      for (int i = 0; i < r.x; ++i) {
        const glm::ivec3 c(i, j, k);
        const glm::dvec3 lo(m.majorantCellLo(c)), hi(m.majorantCellHi(c));
        double t0 = 0.0, t1 = tMax;
        for (int a = 0; a < 3; ++a) {
          if (dir[a] == 0.0f) {
            if (o[a] < lo[a] || o[a] > hi[a]) t1 = -1.0;
            continue;
          }
          double n = (lo[a] - o[a]) / double(dir[a]), f = (hi[a] - o[a]) / double(dir[a]);
          if (n > f) std::swap(n, f);
          t0 = std::max(t0, n), t1 = std::min(t1, f);
        }
        if (t1 - t0 > eps) out.push_back({c, t0, t1});
      }
  std::sort(out.begin(), out.end(), [](const Piece& a, const Piece& b) { return a.t0 < b.t0; });
  return out;
}

GridMedium makeRandomGrid(const glm::ivec3& majorantRes) {
  const glm::ivec3 res(9, 6, 5);
  return GridMedium(Vec3(-1.0f, 0.5f, 2.0f), Vec3(2.0f, 1.5f, 2.7f), res, randomDensities(res, 4, 0.3f),
                    Spectrum(0.2f, 0.6f, 1.0f), Spectrum(0.8f, 0.4f, 2.0f), 0.0f, majorantRes);
}

// The largest density met at random points of each majorant cell never exceeds its majorant.
void checkMajorantBounds(const GridMedium& m, int samplesPerCell) {
  test::UniformRng rng(2);
  const glm::ivec3 r = m.majorantResolution();
  for (int k = 0; k < r.z; ++k)
    for (int j = 0; j < r.y; ++j)
      for (int i = 0; i < r.x; ++i) {
        const glm::ivec3 c(i, j, k);
        float seen = 0.0f;
        for (int s = 0; s < samplesPerCell; ++s) {
          const Vec3 u(rng.next(), rng.next(), rng.next());
          const Vec3 p = m.majorantCellLo(c) + u * (m.majorantCellHi(c) - m.majorantCellLo(c));
          seen = std::max(seen, m.density(p));
        }
        ASSERT_LE(seen, m.majorantDensity(c) * (1.0f + 1e-6f)) << i << " " << j << " " << k;
      }
}

TEST(GridMedium, MajorantBoundsTheDensityInEachCell) {
  const GridMedium m = makeRandomGrid(glm::ivec3(4, 3, 2));
  checkMajorantBounds(m, 2000);
  // Not uselessly loose either: the bound is a max over a few voxels near the cell.
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) EXPECT_LE(m.majorantDensity(glm::ivec3(i, j, k)), 2.0f);
  EXPECT_EQ(m.density(Vec3(-1.5f, 1.0f, 2.3f)), 0.0f);  // outside the box
  // A single spike, in turn at every voxel of a grid whose voxels straddle the majorant cells'
  // faces: its trilinear support must be covered by every cell it reaches.
  const glm::ivec3 res(7, 5, 3);
  for (int v = 0; v < res.x * res.y * res.z; ++v) {
    std::vector<float> density(size_t(res.x * res.y * res.z), 0.0f);
    density[size_t(v)] = 1.0f;
    const GridMedium spike(Vec3(0.0f), Vec3(1.0f), res, density, Spectrum(1.0f), Spectrum(0.0f), 0.0f,
                           glm::ivec3(3, 2, 2));
    checkMajorantBounds(spike, 300);
    if (HasFatalFailure()) FAIL() << "spike at voxel " << v;
  }
}

TEST(GridMedium, DdaVisitsExactlyTheCellsASegmentCrosses) {
  const GridMedium m = makeRandomGrid(glm::ivec3(5, 7, 3));
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int checkedPieces = 0;
  for (int ray = 0; ray < 3000; ++ray) {
    // Origins inside and around the box, random directions (some along an axis), random lengths.
    const Vec3 o(0.5f + 2.0f * u(rng), 1.0f + 0.8f * u(rng), 2.35f + 0.6f * u(rng));
    Vec3 dir = glm::normalize(Vec3(u(rng), u(rng), u(rng)));
    if (ray % 10 == 0) dir = Vec3(0.0f, 0.0f, ray % 20 == 0 ? 1.0f : -1.0f);
    const float tMax = ray % 3 == 0 ? INFINITY : 3.0f * (u(rng) + 1.0f);
    std::vector<Piece> dda;
    m.forEachMajorantSegment(o, dir, tMax, [&](const glm::ivec3& c, float t0, float t1, float maj) {
      EXPECT_EQ(maj, m.majorantDensity(c));
      dda.push_back({c, t0, t1});
      return true;
    });
    const double eps = 1e-5;
    const std::vector<Piece> brute = bruteForceCells(m, o, dir, tMax, eps);
    // Pieces shorter than eps (grazing a cell's edge or corner) may be seen by one and not the other.
    std::vector<Piece> ddaLong;
    for (size_t i = 0; i < dda.size(); ++i) {
      if (i > 0) {
        EXPECT_NEAR(dda[i].t0, dda[i - 1].t1, 1e-6) << "pieces must be contiguous";
      }
      if (dda[i].t1 - dda[i].t0 > eps) ddaLong.push_back(dda[i]);
    }
    ASSERT_EQ(ddaLong.size(), brute.size()) << "ray " << ray;
    for (size_t i = 0; i < brute.size(); ++i) {
      EXPECT_EQ(ddaLong[i].cell, brute[i].cell) << "ray " << ray << " piece " << i;
      EXPECT_NEAR(ddaLong[i].t0, brute[i].t0, 1e-5);
      EXPECT_NEAR(ddaLong[i].t1, brute[i].t1, 1e-5);
      ++checkedPieces;
    }
  }
  EXPECT_GT(checkedPieces, 4000);
}

// Counts the uniform numbers a tracker draws.
struct CountingUniform {
  test::UniformRng* rng;
  int* count;
  float operator()() const {
    ++*count;
    return rng->next();
  }
};

struct Moments {
  double sum = 0.0, sum2 = 0.0;
  int n = 0;
  void add(double x) { sum += x, sum2 += x * x, ++n; }
  double mean() const { return sum / n; }
  double standardError() const { return std::sqrt(std::max(0.0, sum2 / n - mean() * mean()) / n); }
};

// Both trackers on one ray, n times each, against an expected optical depth per channel.
void checkTrackers(const GridMedium& m, const Vec3& o, const Vec3& dir, float tMax, const Spectrum& tau, int n) {
  test::UniformRng rng(21);
  int draws = 0;
  const CountingUniform uniform{&rng, &draws};
  for (int c = 0; c < 3; ++c) {
    Moments ratio, delta;
    for (int i = 0; i < n; ++i) {
      ratio.add(m.ratioTrackingTransmittance(o, dir, tMax, uniform)[c]);
      delta.add(m.deltaTrackingTransmittance(o, dir, tMax, c, uniform));
    }
    const double expected = std::exp(-double(tau[c]));
    EXPECT_NEAR(ratio.mean(), expected, 3 * ratio.standardError() + 1e-6) << "ratio, channel " << c;
    EXPECT_NEAR(delta.mean(), expected, 3 * delta.standardError() + 1e-6) << "delta, channel " << c;
    const double both = std::hypot(ratio.standardError(), delta.standardError());
    EXPECT_NEAR(ratio.mean(), delta.mean(), 3 * both) << "channel " << c;
    EXPECT_LT(ratio.standardError(), delta.standardError()) << "ratio tracking should be the less noisy";
  }
}

TEST(GridMedium, TrackingMatchesTheAnalyticOpticalDepthOfALinearRamp) {
  // Densities rising linearly along x at the voxel centres: between the first and last centres
  // the trilinear density is exactly linear, rho = 0.2 + 1.8 x / 2 (box x in [0, 2]), so along a
  // segment inside that range int sigma_t = sigma_t,scale |p1 - p0| (rho(p0) + rho(p1)) / 2.
  const glm::ivec3 res(16, 3, 2);
  std::vector<float> density(size_t(res.x * res.y * res.z));
  for (int z = 0; z < res.z; ++z)
    for (int y = 0; y < res.y; ++y)
      for (int x = 0; x < res.x; ++x)
        density[size_t((z * res.y + y) * res.x + x)] = 0.2f + 1.8f * (float(x) + 0.5f) / 16.0f;
  const GridMedium m(Vec3(0.0f), Vec3(2.0f, 1.0f, 1.0f), res, density, Spectrum(0.1f, 0.5f, 1.0f),
                     Spectrum(0.2f, 0.4f, 1.2f), 0.0f, glm::ivec3(4, 2, 2));
  const Vec3 p0(0.2f, 0.1f, 0.9f), p1(1.8f, 0.8f, 0.2f);
  const float len = glm::length(p1 - p0);
  const auto rho = [](const Vec3& p) { return 0.2f + 0.9f * p.x; };
  EXPECT_NEAR(m.density(p0), rho(p0), 1e-5f);
  EXPECT_NEAR(m.density(0.5f * (p0 + p1)), rho(0.5f * (p0 + p1)), 1e-5f);
  const Spectrum tau = m.sigmaTScale() * (len * 0.5f * (rho(p0) + rho(p1)));
  checkTrackers(m, p0, (p1 - p0) / len, len, tau, 100000);
}

TEST(GridMedium, DeltaAndRatioTrackingAgreeOnAHeterogeneousGrid) {
  const GridMedium m = makeRandomGrid(glm::ivec3(4, 3, 2));
  const Vec3 o(-1.5f, 0.6f, 2.1f), p1(2.5f, 1.4f, 2.6f);
  const Vec3 dir = glm::normalize(p1 - o);
  const float tMax = glm::length(p1 - o);
  // The optical depth by the midpoint rule on 200k steps (the density is piecewise smooth: error
  // far below the trackers' noise).
  double depth = 0.0;
  constexpr int kSteps = 200000;
  for (int i = 0; i < kSteps; ++i) depth += m.density(o + dir * (tMax * (float(i) + 0.5f) / kSteps));
  depth *= tMax / kSteps;
  ASSERT_GT(depth, 0.3);
  checkTrackers(m, o, dir, tMax, m.sigmaTScale() * float(depth), 100000);
}

TEST(GridMedium, EmptySpaceDrawsNoRandomNumbers) {
  // Density only in the +x quarter: a ray through the -x side crosses majorant cells of 0 only.
  const glm::ivec3 res(8, 4, 4);
  std::vector<float> density(size_t(res.x * res.y * res.z), 0.0f);
  for (int z = 0; z < res.z; ++z)
    for (int y = 0; y < res.y; ++y)
      for (int x = 6; x < res.x; ++x) density[size_t((z * res.y + y) * res.x + x)] = 3.0f;
  const GridMedium m(Vec3(0.0f), Vec3(1.0f), res, density, Spectrum(1.0f), Spectrum(1.0f), 0.0f, glm::ivec3(4));
  test::UniformRng rng(1);
  int draws = 0;
  const CountingUniform uniform{&rng, &draws};
  EXPECT_EQ(m.ratioTrackingTransmittance(Vec3(0.1f, -1.0f, 0.5f), Vec3(0, 1, 0), 10.0f, uniform), Spectrum(1.0f));
  EXPECT_EQ(m.deltaTrackingTransmittance(Vec3(0.1f, -1.0f, 0.5f), Vec3(0, 1, 0), 10.0f, 1, uniform), 1.0f);
  EXPECT_EQ(draws, 0);
  // Through the dense side it does draw, and attenuates.
  EXPECT_LT(m.ratioTrackingTransmittance(Vec3(0.95f, -1.0f, 0.5f), Vec3(0, 1, 0), 10.0f, uniform).r, 1.0f);
  EXPECT_GT(draws, 0);
}

TEST(GridMedium, BadInputNamesTheField) {
  const glm::ivec3 res(2, 2, 2);
  const std::vector<float> ok(8, 1.0f);
  const auto check = [&](const glm::ivec3& r, const std::vector<float>& d, Vec3 hi, Spectrum sa, float g,
                         const std::string& field) {
    try {
      validateGridMedium(Vec3(0.0f), hi, r, d, sa, Spectrum(0.5f), g, "scene.json", "media[1]");
      ADD_FAILURE() << "no error for " << field;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "scene.json");
      EXPECT_NE(std::string(e.what()).find("media[1]." + field + ":"), std::string::npos) << e.what();
    }
  };
  check(res, std::vector<float>(7, 1.0f), Vec3(1.0f), Spectrum(0.1f), 0.0f, "density");
  check(res, std::vector<float>(9, 1.0f), Vec3(1.0f), Spectrum(0.1f), 0.0f, "density");
  check(glm::ivec3(2, 0, 2), std::vector<float>(), Vec3(1.0f), Spectrum(0.1f), 0.0f, "resolution");
  std::vector<float> negative = ok;
  negative[5] = -1.0f;
  check(res, negative, Vec3(1.0f), Spectrum(0.1f), 0.0f, "density[5]");
  negative[5] = NAN;
  check(res, negative, Vec3(1.0f), Spectrum(0.1f), 0.0f, "density[5]");
  check(res, ok, Vec3(1.0f, 0.0f, 1.0f), Spectrum(0.1f), 0.0f, "bounds");
  check(res, ok, Vec3(1.0f), Spectrum(-0.1f), 0.0f, "sigma_a");
  check(res, ok, Vec3(1.0f), Spectrum(0.1f), 1.0f, "g");
  EXPECT_NO_THROW(validateGridMedium(Vec3(0.0f), Vec3(1.0f), res, ok, Spectrum(0.1f), Spectrum(0.5f), 0.3f,
                                     "scene.json", "media[1]"));
}

}  // namespace
}  // namespace lensfarm
