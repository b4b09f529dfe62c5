// Adaptive sampling's allocation (film/adaptive_allocation.h): Neyman's rule against its
// analytic counts on a film of known noise, the floor, the budget, and exact bytes.
#include <gtest/gtest.h>

#include <random>

#include "common/film/adaptive_allocation.h"

namespace lensfarm {
namespace {

// A 32 x 16 film whose left half has per-sample standard deviation 1 and right half `rightSigma`
// (mean 5 everywhere), after `units` uniform units of `perUnit` samples: Gaussian samples from a
// fixed seed, summed per unit as a renderer would.
struct NoisyFilm {
  Sensor film{32, 16};
  ConvergenceTracker halves{32, 16};
  NoisyFilm(double rightSigma, int units, uint32_t perUnit) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int u = 0; u < units; ++u) {
      SensorBuffer b(32, 16);
      for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 32; ++i) {
          const double sigma = i < 16 ? 1.0 : rightSigma;
          for (uint32_t s = 0; s < perUnit; ++s) {
            const double v = 5.0 + sigma * normal(rng);
            for (int c = 0; c < 3; ++c) b.sums[3 * (size_t(j) * 32 + size_t(i)) + size_t(c)] += v;
          }
        }
      film.add(b, perUnit);
      halves.add(uint64_t(u), b, perUnit);
    }
  }
};

AllocationRequest request(uint32_t units) {
  AllocationRequest r;
  r.start = 4;
  r.units = units;
  r.passSamples = 4;
  r.blockEdge = 8;
  r.floor = 0.125;
  return r;
}

uint64_t spent(const RoundAllocation& a) { return a.unitSamples(32, 16); }

TEST(AdaptiveAllocation, FinalCountsFollowTheStandardDeviationAsNeymanSays) {
  // 16 samples a cell so far; a round of 8 units of 4 samples on average brings the mean to 48.
  // Neyman: final N proportional to sigma, N_left + N_right = 96 with N_right = 2 N_left, so
  // N_left = 32, N_right = 64: the left blocks get (32 - 16) / 8 = 2 a unit, the right (64 - 16) / 8 = 6.
  const NoisyFilm f(2.0, 4, 4);
  const RoundAllocation a = allocateRound(f.film, f.halves, request(8));
  ASSERT_EQ(a.base.blocksX, 4);
  ASSERT_EQ(a.base.blocksY, 2);
  for (int by = 0; by < 2; ++by)
    for (int bx = 0; bx < 4; ++bx) {
      const size_t b = size_t(by) * 4 + size_t(bx);
      EXPECT_NEAR(double(a.base.count[b]), bx < 2 ? 2.0 : 6.0, 1.0) << "block " << b;
      EXPECT_EQ(a.base.first[b], 8u) << "each half holds 8 of the 16 samples";
    }
  // Whole samples, never past the budget (4 a cell a unit), short of it by less than one block's cells.
  EXPECT_LE(spent(a), uint64_t(4) * 32 * 16);
  EXPECT_GT(spent(a), uint64_t(4) * 32 * 16 - 64);
}

TEST(AdaptiveAllocation, ABlockAlreadyPastItsShareGetsTheFloorAndTheRestGoesToTheNoisy) {
  // sigma 3 on the right: N_left + N_right = 2 (16 + 2 * 4) = 48, N_right = 3 N_left -> N_left = 12,
  // fewer than the 16 held: the left blocks get the floor, 1 a unit (1/8 of 4, at least 1), and
  // the right blocks the rest of the budget: 8 - 1 = 7 a unit.
  // Each block's sigma is estimated from its 64 cells (about 9 % off on one channel), so one right
  // block may take more than another; the right blocks' mean is the budget's rest exactly.
  const NoisyFilm f(3.0, 4, 4);
  const RoundAllocation a = allocateRound(f.film, f.halves, request(2));
  uint32_t right = 0;
  for (size_t b = 0; b < 8; ++b) {
    if (b % 4 < 2) {
      EXPECT_EQ(a.base.count[b], 1u) << "block " << b;
    } else {
      EXPECT_NEAR(double(a.base.count[b]), 7.0, 3.0) << "block " << b;
      right += a.base.count[b];
    }
  }
  EXPECT_EQ(right, 4u * 7u);
  EXPECT_EQ(spent(a), uint64_t(4) * 32 * 16);
}

TEST(AdaptiveAllocation, ANoiselessFilmIsSampledUniformly) {
  Sensor film(32, 16);
  ConvergenceTracker halves(32, 16);
  SensorBuffer b(32, 16);
  std::fill(b.sums.begin(), b.sums.end(), 8.0);  // every sample 2: no difference between the halves
  for (uint64_t u = 0; u < 4; ++u) {
    film.add(b, 4);
    halves.add(u, b, 4);
  }
  const RoundAllocation a = allocateRound(film, halves, request(2));
  for (uint32_t n : a.base.count) EXPECT_EQ(n, 4u);
}

TEST(AdaptiveAllocation, TheCapKeepsOneNoisyBlockFromTakingTheRound) {
  // One block of sigma 1000 among 63 of sigma 1 (64 x 64 cells): Neyman would give it nearly the
  // whole round (it could take 193 a unit); the cap holds it to 16 x the mean (64 a unit), and the
  // other blocks share the rest above their floor.
  Sensor film(64, 64);
  ConvergenceTracker halves(64, 64);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (uint64_t u = 0; u < 4; ++u) {
    SensorBuffer b(64, 64);
    for (size_t c = 0; c < b.cells(); ++c) {
      const double v = 5.0 + (c % 64 < 8 && c / 64 < 8 ? 1000.0 : 1.0) * normal(rng);
      for (int k = 0; k < 3; ++k) b.sums[3 * c + size_t(k)] = v;
    }
    film.add(b, 1);
    halves.add(u, b, 1);
  }
  const RoundAllocation a = allocateRound(film, halves, request(2));
  EXPECT_EQ(a.base.count[0], uint32_t(kAllocationCap * 4));
  uint64_t others = 0;
  for (size_t b = 1; b < 64; ++b) others += a.base.count[b];
  EXPECT_GT(others, 63u) << "the rest of the budget goes to the other blocks, above their floor of 1";
  EXPECT_LE(a.unitSamples(64, 64), uint64_t(4) * 64 * 64);
}

TEST(AdaptiveAllocation, EachHalfsUnitsTraceConsecutiveRangesOfItsSequence) {
  const NoisyFilm f(2.0, 4, 4);
  const RoundAllocation a = allocateRound(f.film, f.halves, request(6));
  for (size_t b = 0; b < 8; ++b) {
    uint64_t next[2] = {a.base.first[b], a.base.first[b]};
    for (uint64_t u = a.start; u < a.start + a.units; ++u) {
      const auto map = a.mapOf(u);
      EXPECT_EQ(map->half, uint32_t(u & 1));
      EXPECT_EQ(map->first[b], next[u & 1]) << "unit " << u << " block " << b;
      next[u & 1] += map->count[b];
    }
    EXPECT_EQ(next[0], next[1]) << "both halves get the same samples";
  }
  EXPECT_THROW(a.mapOf(a.start + a.units), std::invalid_argument);
}

TEST(AdaptiveAllocation, TheSameFilmGivesTheSameBytesAndTheyRoundTrip) {
  const NoisyFilm f(2.0, 4, 4), g(2.0, 4, 4);
  const RoundAllocation a = allocateRound(f.film, f.halves, request(8));
  EXPECT_EQ(a.serialize(), allocateRound(g.film, g.halves, request(8)).serialize());
  const RoundAllocation back = RoundAllocation::deserialize(a.serialize());
  EXPECT_EQ(back.serialize(), a.serialize());
  EXPECT_EQ(back.base.count, a.base.count);
  std::string bad = a.serialize();
  bad.pop_back();
  EXPECT_THROW(RoundAllocation::deserialize(bad), std::runtime_error);
  EXPECT_THROW(RoundAllocation::deserialize("LLALLOv1"), std::runtime_error);
}

TEST(AdaptiveAllocation, SampleIndicesOfTheTwoHalvesAreThoseOfTheEvenAndOddPasses) {
  SampleMap m;
  m.passSamples = 4;
  m.half = 0;
  EXPECT_EQ(m.sampleIndex(0), 0u);
  EXPECT_EQ(m.sampleIndex(3), 3u);
  EXPECT_EQ(m.sampleIndex(4), 8u);  // the next even pass
  m.half = 1;
  EXPECT_EQ(m.sampleIndex(0), 4u);
  EXPECT_EQ(m.sampleIndex(5), 13u);
}

TEST(AdaptiveAllocation, AMapThatDoesNotFitTheFrameSaysWhy) {
  SampleMap m;
  m.passSamples = 4;
  m.blockEdge = 8;
  m.blocksX = 4;
  m.blocksY = 2;
  m.first.assign(8, 0);
  m.count.assign(8, 1);
  EXPECT_EQ(m.whyNotFor(32, 16), "");
  EXPECT_NE(m.whyNotFor(33, 16).find("do not cover"), std::string::npos);
  m.count.pop_back();
  EXPECT_NE(m.whyNotFor(32, 16).find("7 counts for 8 blocks"), std::string::npos);
  m.count.push_back(1);
  m.half = 2;
  EXPECT_NE(m.whyNotFor(32, 16).find("half 2"), std::string::npos);
}

}  // namespace
}  // namespace lensfarm
