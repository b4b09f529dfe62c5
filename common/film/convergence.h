#pragma once
// A live estimate of how far a progressive image still is from converged, from the image
// itself: no reference needed (docs/accuracy.md, "Live error").
//
// The units of a job are split by parity into two half-images: A (even units) and B (odd
// units), whose samples are disjoint and identically distributed. For each pixel and channel
// the difference d = mean_A - mean_B has expected square Var(mean_A) + Var(mean_B); with n_A
// and n_B samples and per-sample variance s^2 that is s^2 (1/n_A + 1/n_B), while the full
// image (n = n_A + n_B samples) has variance s^2 / n. So
//     Var(full) ~ d^2 * n_A * n_B / n^2,
// and averaging over every pixel and channel gives an estimate of the full image's mean
// squared error that is accurate to a fraction of a percent on any real frame (it averages
// hundreds of thousands of independent squares). The relative RMSE divides its root by the
// image's mean, the same normalisation as film/error_metrics.h uses against a reference.
//
// Only the even half is stored; B = total - A. Units cover the whole frame (render/unit_renderer.h),
// so every cell has the same number of samples in each half, except once adaptive units (render/
// sample_map.h) gave blocks their own counts: then the even count is kept per cell, and the
// formula above holds cell by cell.
//
// The estimate sees noise only, not bias (a bounce limit), and it assumes the two halves are
// independent: the samplers make them so (render/sampler.h: the Sobol sampler draws even and odd
// units from two independently scrambled replicates; stratified patterns are per unit). How well
// it tracks the true error is measured in docs/accuracy.md.
#include <cstdint>
#include <string>
#include <vector>

#include "common/film/sample_map.h"
#include "common/film/sensor.h"

namespace lensfarm {

// valid is false while the relative error cannot be computed, and the error is then unknown, never
// 0: before both halves hold samples, and while the image's mean radiance is not a positive finite
// number (an image black so far, e.g. a small or hidden light no path has found yet, has no
// relative error). No stopping rule may act on an estimate that is not valid.
struct ErrorEstimate {
  bool valid = false;
  double rmse = 0.0;          // estimated RMSE over pixels and channels, in radiance (0 before both halves)
  double relativeRmse = 0.0;  // rmse / mean radiance; meaningful only if valid
  double mean = 0.0;          // mean radiance over pixels and channels (0 before both halves)
};

class ConvergenceTracker {
 public:
  ConvergenceTracker(int width, int height);

  // Adds unit `unitIndex`'s buffer to its half (call it for every unit added to the sensor).
  void add(uint64_t unitIndex, const SensorBuffer& unit);
  // The same for a unit whose every cell holds `samplesPerCell` samples (its counts are not read).
  void add(uint64_t unitIndex, const SensorBuffer& unit, uint32_t samplesPerCell);

  // The same for an adaptive unit: each cell holds the samples `counts` gives it (film/sample_map.h).
  void add(uint64_t unitIndex, const SensorBuffer& unit, const SampleMap& counts);

  // Cell (i, j)'s per-sample variance, estimated from the halves and averaged over RGB:
  //     s^2 ~ d^2 n_A n_B / n  (Var(mean) = s^2 / n, above);
  // -1 while a half holds no sample. `mean`, if given, gets the cell's R + G + B mean.
  double cellVariance(const Sensor& total, int i, int j, double* mean = nullptr) const;

  // The estimate for `total`, the sensor holding every unit added here.
  ErrorEstimate estimate(const Sensor& total) const;

  // Exact state, for checkpoints (the coordinator saves it beside the sensor); deserialize
  // throws std::runtime_error on bytes that are not a tracker.
  std::string serialize() const;
  static ConvergenceTracker deserialize(const std::string& bytes);
  // The same for a tracker at the start of `bytes`, followed by anything: `used` gets its size.
  static ConvergenceTracker deserializePrefix(const std::string& bytes, size_t& used);

  // Bytes of frame-sized memory held (farm/memory_estimate.h: kTrackerBytesPerCell a cell).
  uint64_t memoryBytes() const {
    return evenSums_.capacity() * sizeof(double) + evenCounts_.capacity() * sizeof(uint64_t);
  }

 private:
  int width_, height_;
  size_t checkedStride(const SensorBuffer& unit) const;
  std::vector<double> evenSums_;      // 3 per cell
  uint64_t evenSamples_ = 0;          // per cell, while every cell has the same even count
  std::vector<uint64_t> evenCounts_;  // per cell once adaptive units gave cells different counts
};

// Seconds more until `estimate` falls to `target`, if error falls as 1/sqrt(time) (Monte Carlo
// noise at a constant rate), given `elapsed` seconds so far; 0 if already there or unknown.
double secondsToTarget(double estimate, double target, double elapsed);

}  // namespace lensfarm
