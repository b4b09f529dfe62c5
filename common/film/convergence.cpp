#include "common/film/convergence.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace lensfarm {

namespace {
constexpr uint64_t kMagic = 0x31764e4f43464c4cull;    // "LLFCONv1": every cell's even count the same
constexpr uint64_t kMagicV2 = 0x32764e4f43464c4cull;  // "LLFCONv2": per-cell even counts follow the sums
}  // namespace

ConvergenceTracker::ConvergenceTracker(int width, int height)
    : width_(width), height_(height), evenSums_(size_t(width) * height * 3, 0.0) {}

void ConvergenceTracker::add(uint64_t unitIndex, const SensorBuffer& unit) {
  if (unit.width != width_ || unit.height != height_)
    throw std::invalid_argument("ConvergenceTracker::add: buffer size differs from the tracker's");
  if (unitIndex % 2 != 0 || unit.samples.empty()) return;
  add(unitIndex, unit, unit.samples[0]);
}

size_t ConvergenceTracker::checkedStride(const SensorBuffer& unit) const {
  // The beauty's RGB only: the first 3 of each cell's sums (film/sensor.h), however many it has.
  const size_t stride = unit.cells() ? unit.sums.size() / unit.cells() : 3;
  if (unit.width != width_ || unit.height != height_ || stride < 3 || unit.sums.size() != unit.cells() * stride)
    throw std::invalid_argument("ConvergenceTracker::add: buffer size differs from the tracker's");
  return stride;
}

void ConvergenceTracker::add(uint64_t unitIndex, const SensorBuffer& unit, uint32_t samplesPerCell) {
  const size_t stride = checkedStride(unit);
  if (unitIndex % 2 != 0) return;
  for (size_t c = 0; c < unit.cells(); ++c)
    for (size_t k = 0; k < 3; ++k) evenSums_[3 * c + k] += unit.sums[stride * c + k];
  evenSamples_ += samplesPerCell;
  for (uint64_t& n : evenCounts_) n += samplesPerCell;
}

void ConvergenceTracker::add(uint64_t unitIndex, const SensorBuffer& unit, const SampleMap& counts) {
  const size_t stride = checkedStride(unit);
  if (unitIndex % 2 != 0) return;
  if (evenCounts_.empty()) evenCounts_.assign(unit.cells(), evenSamples_);
  for (int j = 0; j < height_; ++j)
    for (int i = 0; i < width_; ++i) {
      const size_t c = size_t(j) * size_t(width_) + size_t(i);
      for (size_t k = 0; k < 3; ++k) evenSums_[3 * c + k] += unit.sums[stride * c + k];
      evenCounts_[c] += counts.countAt(i, j);
    }
}

double ConvergenceTracker::cellVariance(const Sensor& total, int i, int j, double* meanOut) const {
  const size_t cell = size_t(j) * size_t(width_) + size_t(i);
  const double n = double(total.samples(i, j));
  const double nA = double(evenCounts_.empty() ? evenSamples_ : evenCounts_[cell]), nB = n - nA;
  const DVec3 m = total.mean(i, j);
  if (meanOut) *meanOut = m[0] + m[1] + m[2];
  if (nA <= 0.0 || nB <= 0.0) return -1.0;
  const double* a = &evenSums_[3 * cell];
  double squares = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double d = a[c] / nA - (m[c] * n - a[c]) / nB;
    squares += d * d;
  }
  return squares * nA * nB / n / 3.0;
}

ErrorEstimate ConvergenceTracker::estimate(const Sensor& total) const {
  ErrorEstimate e;
  if (total.width() != width_ || total.height() != height_ || total.totalSamples() == 0) return e;
  double variance = 0.0, mean = 0.0;
  for (int j = 0; j < height_; ++j)
    for (int i = 0; i < width_; ++i) {
      double cellMean = 0.0;
      const double v = cellVariance(total, i, j, &cellMean);
      if (v < 0.0) return e;
      variance += 3.0 * v / double(total.samples(i, j));  // the cell's mean's variance, 3 channels
      mean += cellMean;
    }
  const double count = 3.0 * double(width_) * double(height_);
  e.rmse = std::sqrt(variance / count);
  e.mean = mean / count;
  // Without a positive mean there is no relative error: unknown (valid false), not 0.
  if (!(e.mean > 0.0) || !std::isfinite(e.mean) || !std::isfinite(e.rmse)) return e;
  e.valid = true;
  e.relativeRmse = e.rmse / e.mean;
  return e;
}

std::string ConvergenceTracker::serialize() const {
  const uint64_t header[4] = {evenCounts_.empty() ? kMagic : kMagicV2, uint64_t(width_), uint64_t(height_),
                              evenSamples_};
  std::string out(sizeof header + evenSums_.size() * sizeof(double) + evenCounts_.size() * sizeof(uint64_t), '\0');
  std::memcpy(out.data(), header, sizeof header);
  std::memcpy(out.data() + sizeof header, evenSums_.data(), evenSums_.size() * sizeof(double));
  if (!evenCounts_.empty())
    std::memcpy(out.data() + sizeof header + evenSums_.size() * sizeof(double), evenCounts_.data(),
                evenCounts_.size() * sizeof(uint64_t));
  return out;
}

ConvergenceTracker ConvergenceTracker::deserialize(const std::string& bytes) {
  size_t used = 0;
  ConvergenceTracker t = deserializePrefix(bytes, used);
  if (used != bytes.size()) throw std::runtime_error("convergence state: wrong size");
  return t;
}

ConvergenceTracker ConvergenceTracker::deserializePrefix(const std::string& bytes, size_t& used) {
  uint64_t header[4];
  if (bytes.size() < sizeof header) throw std::runtime_error("convergence state: truncated");
  std::memcpy(header, bytes.data(), sizeof header);
  if ((header[0] != kMagic && header[0] != kMagicV2) || header[1] == 0 || header[2] == 0 || header[1] > (1u << 16) ||
      header[2] > (1u << 16))
    throw std::runtime_error("convergence state: not a lensfarm tracker");
  ConvergenceTracker t{int(header[1]), int(header[2])};
  const size_t sums = t.evenSums_.size() * sizeof(double);
  const size_t counts = header[0] == kMagicV2 ? t.evenSums_.size() / 3 * sizeof(uint64_t) : 0;
  used = sizeof header + sums + counts;
  if (bytes.size() < used) throw std::runtime_error("convergence state: wrong size");
  t.evenSamples_ = header[3];
  std::memcpy(t.evenSums_.data(), bytes.data() + sizeof header, sums);
  if (counts) {
    t.evenCounts_.resize(t.evenSums_.size() / 3);
    std::memcpy(t.evenCounts_.data(), bytes.data() + sizeof header + sums, counts);
  }
  return t;
}

double secondsToTarget(double estimate, double target, double elapsed) {
  if (!(estimate > target) || target <= 0.0 || elapsed <= 0.0) return 0.0;
  const double ratio = estimate / target;
  return elapsed * (ratio * ratio - 1.0);
}

}  // namespace lensfarm
