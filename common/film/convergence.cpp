#include "film/convergence.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace lensfarm {

namespace {
constexpr uint64_t kMagic = 0x31764e4f43464c4cull;  // "LLFCONv1"
}

ConvergenceTracker::ConvergenceTracker(int width, int height)
    : width_(width), height_(height), evenSums_(size_t(width) * height * 3, 0.0) {}

void ConvergenceTracker::add(uint64_t unitIndex, const SensorBuffer& unit) {
  if (unit.width != width_ || unit.height != height_)
    throw std::invalid_argument("ConvergenceTracker::add: buffer size differs from the tracker's");
  if (unitIndex % 2 != 0 || unit.samples.empty()) return;
  add(unitIndex, unit, unit.samples[0]);
}

void ConvergenceTracker::add(uint64_t unitIndex, const SensorBuffer& unit, uint32_t samplesPerCell) {
  // The beauty's RGB only: the first 3 of each cell's sums (film/sensor.h), however many it has.
  const size_t stride = unit.cells() ? unit.sums.size() / unit.cells() : 3;
  if (unit.width != width_ || unit.height != height_ || stride < 3 || unit.sums.size() != unit.cells() * stride)
    throw std::invalid_argument("ConvergenceTracker::add: buffer size differs from the tracker's");
  if (unitIndex % 2 != 0) return;
  for (size_t c = 0; c < unit.cells(); ++c)
    for (size_t k = 0; k < 3; ++k) evenSums_[3 * c + k] += unit.sums[stride * c + k];
  evenSamples_ += samplesPerCell;
}

ErrorEstimate ConvergenceTracker::estimate(const Sensor& total) const {
  ErrorEstimate e;
  if (total.width() != width_ || total.height() != height_ || total.totalSamples() == 0) return e;
  const double nA = double(evenSamples_);
  double variance = 0.0, mean = 0.0;
  for (int j = 0; j < height_; ++j)
    for (int i = 0; i < width_; ++i) {
      const double n = double(total.samples(i, j)), nB = n - nA;
      if (nA <= 0.0 || nB <= 0.0) return e;
      const DVec3 m = total.mean(i, j);
      const double* a = &evenSums_[3 * (size_t(j) * width_ + i)];
      const double weight = nA * nB / (n * n);
      for (int c = 0; c < 3; ++c) {
        const double d = a[c] / nA - (m[c] * n - a[c]) / nB;
        variance += d * d * weight;
        mean += m[c];
      }
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
  std::string out(sizeof(uint64_t) * 4 + evenSums_.size() * sizeof(double), '\0');
  const uint64_t header[4] = {kMagic, uint64_t(width_), uint64_t(height_), evenSamples_};
  std::memcpy(out.data(), header, sizeof header);
  std::memcpy(out.data() + sizeof header, evenSums_.data(), evenSums_.size() * sizeof(double));
  return out;
}

ConvergenceTracker ConvergenceTracker::deserialize(const std::string& bytes) {
  uint64_t header[4];
  if (bytes.size() < sizeof header) throw std::runtime_error("convergence state: truncated");
  std::memcpy(header, bytes.data(), sizeof header);
  if (header[0] != kMagic || header[1] == 0 || header[2] == 0 || header[1] > (1u << 16) || header[2] > (1u << 16))
    throw std::runtime_error("convergence state: not a lensfarm tracker");
  ConvergenceTracker t{int(header[1]), int(header[2])};
  if (bytes.size() != sizeof header + t.evenSums_.size() * sizeof(double))
    throw std::runtime_error("convergence state: wrong size");
  t.evenSamples_ = header[3];
  std::memcpy(t.evenSums_.data(), bytes.data() + sizeof header, t.evenSums_.size() * sizeof(double));
  return t;
}

double secondsToTarget(double estimate, double target, double elapsed) {
  if (!(estimate > target) || target <= 0.0 || elapsed <= 0.0) return 0.0;
  const double ratio = estimate / target;
  return elapsed * (ratio * ratio - 1.0);
}

}  // namespace lensfarm
