// Error measures against a reference (film/error_metrics.h) and the live estimate without one
// (film/convergence.h), on images whose true error is known by construction.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/film/convergence.h"
#include "common/film/error_metrics.h"

namespace lensfarm {
namespace {

Image constantImage(int w, int h, float value) {
  Image image{w, h, std::vector<float>(size_t(w) * h * 3, value)};
  return image;
}

TEST(ErrorMetrics, MatchTheirDefinitionsOnKnownImages) {
  Image reference = constantImage(8, 4, 2.0f);
  for (size_t k = 0; k < reference.rgb.size(); k += 2) reference.rgb[k] = 4.0f;  // mean 3
  Image image = reference;
  for (size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] += (k % 2 ? -0.3f : 0.3f);  // |error| 0.3 everywhere
  const ImageError e = compareImages(image, reference);
  EXPECT_NEAR(e.rmse, 0.3, 1e-6);
  EXPECT_NEAR(e.relativeRmse, 0.1, 1e-6);
  EXPECT_NEAR(e.meanRatio, 1.0, 1e-6) << "the errors cancel in the mean";
  EXPECT_NEAR(e.relativeMse, 0.5 * (0.09 / 16.01 + 0.09 / 4.01), 1e-7);
  EXPECT_GT(e.displayRmse, 0.0);

  const ImageError same = compareImages(reference, reference);
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_EQ(same.displayRmse, 0.0);
  EXPECT_EQ(same.meanRatio, 1.0);

  // A brighter image of the same picture is a bias: the mean ratio says so, and the displayed
  // picture (automatic exposure) hides it.
  Image brighter = reference;
  for (float& v : brighter.rgb) v *= 2.0f;
  const ImageError bias = compareImages(brighter, reference);
  EXPECT_NEAR(bias.meanRatio, 2.0, 1e-6);
  EXPECT_NEAR(bias.relativeRmse, 1.0 / 3.0 * std::sqrt((4.0 + 16.0) / 2.0), 1e-6);
  EXPECT_LT(bias.displayRmse, 1.0 / 255.0);

  EXPECT_THROW(compareImages(constantImage(2, 2, 1.0f), reference), std::invalid_argument);
}

// Units of `perUnit` samples of Gaussian noise (sigma) around per-pixel means: the true error of
// the accumulated image is sigma / sqrt(n) per value, known without any estimate.
struct SyntheticJob {
  int w = 64, h = 48;
  double sigma = 0.5;
  std::vector<double> truth;
  Sensor sensor{64, 48};
  ConvergenceTracker tracker{64, 48};
  std::mt19937_64 rng{7};
  uint64_t units = 0;

  SyntheticJob() {
    std::uniform_real_distribution<double> level(0.2, 2.0);
    truth.resize(size_t(w) * h * 3);
    for (double& t : truth) t = level(rng);
  }
  void addUnit(uint32_t perUnit) {
    SensorBuffer b(w, h);
    std::normal_distribution<double> noise(0.0, sigma * std::sqrt(double(perUnit)));
    for (size_t k = 0; k < b.sums.size(); ++k) b.sums[k] = truth[k] * perUnit + noise(rng);
    std::fill(b.samples.begin(), b.samples.end(), perUnit);
    sensor.add(b);
    tracker.add(units++, b);
  }
  double meanTruth() const {
    double s = 0;
    for (double t : truth) s += t;
    return s / double(truth.size());
  }
  double actualRelativeError() const {
    double sq = 0;
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i)
        for (int c = 0; c < 3; ++c) {
          const double d = sensor.mean(i, j)[c] - truth[3 * (size_t(j) * w + i) + c];
          sq += d * d;
        }
    return std::sqrt(sq / double(truth.size())) / meanTruth();
  }
};

// The worst 1 % of pixels is the 99th percentile (nearest rank) of the per-pixel relative error:
// of 100 pixels, the 99th worst. Two bad pixels show in it, one alone does not.
TEST(ErrorMetrics, WorstPercentIsTheNinetyNinthPercentileOfPixels) {
  const Image reference = constantImage(10, 10, 1.0f);  // mean 1: the floor is 0.01
  Image twoBad = reference;
  for (size_t k = 0; k < 6; ++k) twoBad.rgb[k] = 1.5f;  // pixels 0 and 1, every channel
  EXPECT_NEAR(compareImages(twoBad, reference).worstPercentRelative, 0.5 / 1.01, 1e-6);
  Image oneBad = reference;
  oneBad.rgb[0] = 4.0f;  // one channel of one pixel: (3 / 1.01) / 3 for that pixel only
  EXPECT_EQ(compareImages(oneBad, reference).worstPercentRelative, 0.0);
  oneBad.rgb[3] = 4.0f;
  EXPECT_NEAR(compareImages(oneBad, reference).worstPercentRelative, 1.0 / 1.01, 1e-6);
}

TEST(Convergence, EstimatesTheErrorOfSyntheticNoiseWithinTenPercent) {
  SyntheticJob job;
  job.addUnit(4);
  EXPECT_FALSE(job.tracker.estimate(job.sensor).valid) << "one half is empty";
  for (int units : {2, 3, 8, 33}) {  // odd counts: halves of unequal size
    while (job.units < uint64_t(units)) job.addUnit(4);
    const ErrorEstimate e = job.tracker.estimate(job.sensor);
    ASSERT_TRUE(e.valid);
    const double expected = job.sigma / std::sqrt(4.0 * units) / job.meanTruth();
    EXPECT_NEAR(e.relativeRmse / expected, 1.0, 0.10) << units << " units";
    EXPECT_NEAR(e.relativeRmse / job.actualRelativeError(), 1.0, 0.10) << units << " units";
  }
}

TEST(Convergence, HalvesOfDifferentUnitSizesStillEstimateTheWholeImage) {
  SyntheticJob job;
  for (uint32_t perUnit : {16u, 1u, 16u, 1u, 7u}) job.addUnit(perUnit);  // even half 39, odd half 2 samples
  const ErrorEstimate e = job.tracker.estimate(job.sensor);
  ASSERT_TRUE(e.valid);
  const double expected = job.sigma / std::sqrt(41.0) / job.meanTruth();
  EXPECT_NEAR(e.relativeRmse / expected, 1.0, 0.10);
}

// The first units of a scene whose light no path has found yet are black in both halves: their
// difference is 0, but so is the mean, and a relative error of 0/0 is unknown, never 0 (a
// target-error job would otherwise stop at its second unit, all black).
TEST(Convergence, AnImageBlackInBothHalvesHasAnUnknownErrorNotZero) {
  constexpr int kW = 8, kH = 4;
  Sensor sensor(kW, kH);
  ConvergenceTracker tracker(kW, kH);
  SensorBuffer black(kW, kH);
  std::fill(black.samples.begin(), black.samples.end(), 2u);
  for (uint64_t unit = 0; unit < 4; ++unit) {
    sensor.add(black);
    tracker.add(unit, black);
  }
  const ErrorEstimate dark = tracker.estimate(sensor);
  EXPECT_FALSE(dark.valid) << "both halves hold samples, but the image is black: no relative error";
  EXPECT_EQ(dark.mean, 0.0);

  // One path finds the light, in the odd half: the error is known, and large.
  SensorBuffer lit = black;
  lit.sums[5] = 40.0;
  sensor.add(lit);
  tracker.add(5, lit);
  const ErrorEstimate found = tracker.estimate(sensor);
  ASSERT_TRUE(found.valid);
  EXPECT_GT(found.mean, 0.0);
  EXPECT_GT(found.relativeRmse, 1.0) << "one hit in 96 values: the estimate is far from converged";
}

TEST(Convergence, SurvivesACheckpointBitForBit) {
  SyntheticJob job;
  for (int u = 0; u < 5; ++u) job.addUnit(3);
  const ConvergenceTracker restored = ConvergenceTracker::deserialize(job.tracker.serialize());
  EXPECT_EQ(restored.estimate(job.sensor).relativeRmse, job.tracker.estimate(job.sensor).relativeRmse);
  EXPECT_EQ(restored.serialize(), job.tracker.serialize());
  EXPECT_THROW(ConvergenceTracker::deserialize("not a tracker"), std::runtime_error);
  std::string truncated = job.tracker.serialize();
  truncated.pop_back();
  EXPECT_THROW(ConvergenceTracker::deserialize(truncated), std::runtime_error);
}

TEST(Convergence, ProjectsTimeToATargetAsOneOverSquareRoot) {
  // Error 2 % after 10 s; 1 % needs four times the samples: 30 s more.
  EXPECT_NEAR(secondsToTarget(0.02, 0.01, 10.0), 30.0, 1e-9);
  EXPECT_EQ(secondsToTarget(0.005, 0.01, 10.0), 0.0) << "already there";
  EXPECT_EQ(secondsToTarget(0.02, 0.01, 0.0), 0.0) << "unknown without elapsed time";
}

}  // namespace
}  // namespace lensfarm
