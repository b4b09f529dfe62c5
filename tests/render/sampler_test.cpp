// The samplers' promises (render/sampler.h): values in [0, 1), pure functions of their counters,
// stratification where it is promised, and lower error than independent samples on a smooth
// integrand.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <set>

#include "common/render/sampler.h"

namespace lensfarm {
namespace {

SamplerSetup setup(SamplerKind kind, uint64_t spp, uint32_t perUnit) { return SamplerSetup{kind, 42, spp, perUnit}; }

TEST(Sampler, ValuesAreInTheUnitIntervalAndPureFunctionsOfTheirCounters) {
  for (SamplerKind kind : {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol}) {
    const SamplerSetup s = setup(kind, 1000, 100);
    for (uint64_t pixel : {0ull, 7ull, 123456789ull})
      for (uint64_t i = 0; i < 1000; i += 37)
        for (uint32_t d = 0; d < 40; ++d) {
          const float v = SampleStream(s, pixel, i).get1D(d);
          const Vec2 p = SampleStream(s, pixel, i).get2D(d);
          ASSERT_TRUE(v >= 0.0f && v < 1.0f) << samplerName(kind);
          ASSERT_TRUE(p.x >= 0.0f && p.x < 1.0f && p.y >= 0.0f && p.y < 1.0f) << samplerName(kind);
          ASSERT_EQ(v, SampleStream(s, pixel, i).get1D(d));
        }
  }
}

// The k-th sample of a Sobol replicate (0: even units, 1: odd units) with units of `perUnit`.
uint64_t replicateSample(uint64_t k, uint32_t perUnit, int replicate) {
  return (k / perUnit) * 2 * perUnit + uint64_t(replicate) * perUnit + k % perUnit;
}

TEST(Sampler, LaneFormsGiveEachStreamsValuesBitForBit) {
  // The vector loops over a packet's streams (lanes1D, lanes2D) against each stream's own get1D
  // and get2D, for every dimension that has a lane form; lanes from different pixels, samples and
  // units, with sample indices past 2^32.
  for (SamplerKind kind : {SamplerKind::kIndependent, SamplerKind::kStratified, SamplerKind::kSobol}) {
    const SamplerSetup s = setup(kind, 1ull << 40, 16);
    SampleStream streams[kPacketWidth];
    for (int k = 0; k < kPacketWidth; ++k)
      streams[k] = SampleStream(s, uint64_t(k) * 977 + 3, (uint64_t(k) << 33) + uint64_t(k) * 5);
    const SampleStream::LaneKeys keys = SampleStream::keysOf(streams);
    EXPECT_EQ(keys.sobol, kind == SamplerKind::kSobol);
    int compared = 0;
    for (uint32_t d = 0; d < 40; ++d) {
      if (!SampleStream::hasLaneForm(keys, d)) continue;
      float v[kPacketWidth], x[kPacketWidth], y[kPacketWidth];
      SampleStream::lanes1D(keys, d, v);
      SampleStream::lanes2D(keys, d, x, y);
      for (int k = 0; k < kPacketWidth; ++k) {
        const Vec2 p = streams[k].get2D(d);
        ASSERT_EQ(std::bit_cast<uint32_t>(v[k]), std::bit_cast<uint32_t>(streams[k].get1D(d))) << d << " " << k;
        ASSERT_EQ(std::bit_cast<uint32_t>(x[k]), std::bit_cast<uint32_t>(p.x)) << d << " " << k;
        ASSERT_EQ(std::bit_cast<uint32_t>(y[k]), std::bit_cast<uint32_t>(p.y)) << d << " " << k;
        ++compared;
      }
    }
    // Every dimension for Sobol; from kStratifiedDimensions on for the others.
    EXPECT_EQ(compared, kPacketWidth * int(kind == SamplerKind::kSobol ? 40 : 40 - kStratifiedDimensions))
        << samplerName(kind);
  }
}

TEST(Sampler, SobolReplicatePrefixesArePowerOfTwoNetsInEveryDimensionPair) {
  // Every power-of-two prefix of an Owen-scrambled Sobol pair is a (0, m, 2)-net: each
  // elementary box of area 2^-m, of any aspect ratio, holds exactly one point. Each replicate
  // (the even units, the odd units) is such a sequence.
  const SamplerSetup s = setup(SamplerKind::kSobol, 1 << 10, 32);
  for (int replicate : {0, 1})
    for (uint64_t pixel : {3ull, 999ull})
      for (uint32_t dim :
           {dims::kSensor, dims::kLens, dims::segment(0) + dims::kMaterial, dims::segment(0) + dims::kLightPoint})
        for (int m : {2, 4, 6, 8}) {
          const uint32_t n = 1u << m;
          for (int xBits = 0; xBits <= m; ++xBits) {
            const int yBits = m - xBits;
            std::set<uint32_t> boxes;
            for (uint32_t i = 0; i < n; ++i) {
              const Vec2 p = SampleStream(s, pixel, replicateSample(i, 32, replicate)).get2D(dim);
              boxes.insert(uint32_t(p.x * float(1u << xBits)) << yBits | uint32_t(p.y * float(1u << yBits)));
            }
            ASSERT_EQ(boxes.size(), n) << "replicate " << replicate << " pixel " << pixel << " dim " << dim << " m "
                                       << m << " x bits " << xBits;
          }
        }
}

TEST(Sampler, SobolReplicatesAreScrambledIndependently) {
  // The same position in the two replicates gives unrelated points.
  const SamplerSetup s = setup(SamplerKind::kSobol, 1 << 10, 16);
  int same = 0;
  for (uint64_t k = 0; k < 256; ++k)
    same += SampleStream(s, 9, replicateSample(k, 16, 0)).get2D(dims::kSensor) ==
            SampleStream(s, 9, replicateSample(k, 16, 1)).get2D(dims::kSensor);
  EXPECT_EQ(same, 0);
}

TEST(Sampler, StratifiedUnitsHoldOneSamplePerStratum) {
  const uint32_t perUnit = 24;
  const SamplerSetup s = setup(SamplerKind::kStratified, 60, perUnit);  // units of 24, 24, 12
  for (uint64_t first : {0ull, 24ull, 48ull}) {
    const uint32_t count = first == 48 ? 12 : perUnit;
    std::set<uint32_t> strata1D, rows, columns;
    for (uint32_t k = 0; k < count; ++k) {
      const SampleStream stream(s, 5, first + k);
      strata1D.insert(uint32_t(stream.get1D(dims::segment(0) + dims::kLightChoice) * float(count)));
      const Vec2 p = stream.get2D(dims::kSensor);
      rows.insert(uint32_t(p.y * float(count)));  // multi-jittered: one per 1/N slab of y
    }
    EXPECT_EQ(strata1D.size(), count) << "unit at " << first;
    EXPECT_EQ(rows.size(), count) << "unit at " << first;
  }
}

// Mean squared error over pixels of estimating the integral of a smooth function over the unit
// square (the pixel footprint, a soft shadow edge) with n samples per pixel.
double integrationError(SamplerKind kind, uint32_t n) {
  const SamplerSetup s = setup(kind, n, n);
  const double exact = (1.0 - std::cos(1.0)) * (std::exp(1.0) - 1.0);  // integral of sin(x) e^y
  double sq = 0.0;
  const int pixels = 400;
  for (int pixel = 0; pixel < pixels; ++pixel) {
    double sum = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
      const Vec2 p = SampleStream(s, uint64_t(pixel), i).get2D(dims::kSensor);
      sum += std::sin(double(p.x)) * std::exp(double(p.y));
    }
    sq += (sum / n - exact) * (sum / n - exact);
  }
  return sq / pixels;
}

TEST(Sampler, StratifiedAndSobolBeatIndependentSamplesOnASmoothIntegrand) {
  const double independent = integrationError(SamplerKind::kIndependent, 64);
  const double stratified = integrationError(SamplerKind::kStratified, 64);
  const double sobol = integrationError(SamplerKind::kSobol, 64);
  // Independent: variance / 64; stratified and Sobol converge as n^-2 or faster for smooth
  // integrands: at 64 samples at least 10x less squared error.
  EXPECT_LT(stratified * 10.0, independent);
  EXPECT_LT(sobol * 10.0, independent);
  // And every sampler is unbiased: independent's error is its variance / n.
  EXPECT_NEAR(independent, 0.2470 / 64.0, 0.25 * 0.2470 / 64.0);
}

}  // namespace
}  // namespace lensfarm
