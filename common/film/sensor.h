#pragma once
// The light sensor (seed §4.7.1): one cell per pixel, RGB radiance sums and a sample count.
//
//  - SensorBuffer is what one unit of work produces: plain double sums over its samples.
//  - Sensor is the accumulated result of many units. Each cell sums units with compensated
//    (Neumaier) summation, so billions of samples lose no precision, and values are never
//    clamped (the seed: "not limited to be less than one").
//  - Cells are indexed in sensor orientation (camera/thin_lens_camera.h); developImage() undoes
//    the lens's flip and returns linear radiance as the viewer expects it, row 0 at the top.
#include <cstdint>
#include <string>
#include <vector>

#include "film/image.h"
#include "math/compensated_sum.h"
#include "math/vec.h"

namespace lensfarm {

struct SensorBuffer {
  int width = 0, height = 0;
  std::vector<double> sums;       // 3 per cell, RGB
  std::vector<uint32_t> samples;  // per cell

  SensorBuffer() = default;
  SensorBuffer(int w, int h) : width(w), height(h), sums(size_t(w) * h * 3, 0.0), samples(size_t(w) * h, 0) {}
  size_t cells() const { return size_t(width) * height; }
};

class Sensor {
 public:
  Sensor(int width, int height);

  // Adds one unit's partial buffer. Callers add units in a canonical order (by unit index) so
  // that the result does not depend on which unit finished first.
  void add(const SensorBuffer& unit);

  int width() const { return width_; }
  int height() const { return height_; }
  uint64_t totalSamples() const { return totalSamples_; }
  uint64_t samples(int i, int j) const { return samples_[size_t(j) * width_ + i]; }
  // Mean radiance of cell (i, j) in sensor orientation; zero before any sample.
  DVec3 mean(int i, int j) const;

  // Mean radiance per pixel, the lens flip undone (image pixel (x, y) = cell (W-1-x, H-1-y)).
  Image developImage() const;

  // The sensor's exact state as bytes (native little-endian doubles), and back: a restored
  // sensor continues to accumulate bit for bit as if it had never been saved. deserialize
  // throws std::runtime_error on bytes that are not a sensor.
  std::string serialize() const;
  static Sensor deserialize(const std::string& bytes);

 private:
  int width_, height_;
  std::vector<CompensatedSum> sums_;  // 3 per cell
  std::vector<uint64_t> samples_;
  uint64_t totalSamples_ = 0;
};

}  // namespace lensfarm
