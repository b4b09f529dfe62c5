#pragma once
// The light sensor (2013 report §4.7.1): one cell per pixel, RGB radiance sums and a sample count.
//
//  - SensorBuffer is what one unit of work produces: plain double sums over its samples.
//  - Sensor is the accumulated result of many units. Each cell sums units with compensated
//    (Neumaier) summation, so billions of samples lose no precision, and values are never
//    clamped (the report: "not limited to be less than one").
//  - A cell holds `channels` sums: the beauty's RGB first, then the AOVs' (film/aov_layout.h),
//    every one summed the same way.
//  - Cells are indexed in sensor orientation (camera/thin_lens_camera.h); developImage() undoes
//    the lens's flip and returns linear radiance as the viewer expects it, row 0 at the top.
#include <cstdint>
#include <string>
#include <vector>

#include "common/film/sample_map.h"

#include "common/film/aov_layout.h"
#include "common/film/image.h"
#include "common/math/compensated_sum.h"
#include "common/math/vec.h"

namespace lensfarm {

struct SensorBuffer {
  int width = 0, height = 0;
  int channels = 3;               // sums per cell: RGB, then the AOVs' (AovLayout::channels)
  std::vector<double> sums;       // `channels` per cell
  std::vector<uint32_t> samples;  // per cell

  SensorBuffer() = default;
  SensorBuffer(int w, int h, int c = 3)
      : width(w), height(h), channels(c), sums(size_t(w) * h * size_t(c), 0.0), samples(size_t(w) * h, 0) {}
  size_t cells() const { return size_t(width) * height; }
  // Bytes of frame-sized memory held (farm/memory_estimate.h: kUnitBufferBytesPerCell a cell).
  uint64_t memoryBytes() const { return sums.capacity() * sizeof(double) + samples.capacity() * sizeof(uint32_t); }
};

class Sensor {
 public:
  Sensor(int width, int height, int channels = 3);

  // Adds one unit's partial buffer. Callers add units in a canonical order (by unit index) so
  // that the result does not depend on which unit finished first.
  void add(const SensorBuffer& unit);
  // The same for a unit whose every cell holds `samplesPerCell` samples (a unit covers the whole
  // frame); the buffer's own counts are not read (the coordinator knows each unit's count).
  void add(const SensorBuffer& unit, uint32_t samplesPerCell);
  // The same for an adaptive unit: each cell holds the samples `counts` gives it (film/sample_map.h).
  void add(const SensorBuffer& unit, const SampleMap& counts);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  uint64_t totalSamples() const { return totalSamples_; }
  uint64_t samples(int i, int j) const { return samples_.empty() ? uniformSamples_ : samples_[size_t(j) * width_ + i]; }
  // The compensated sum of value k (cell k / channels, channel k % channels) as it stands: what a tile unit
  // uploads after folding its passes (render/unit_renderer.cpp).
  double sum(size_t k) const { return sums_[k].value(); }
  // Mean radiance of cell (i, j) in sensor orientation; zero before any sample.
  DVec3 mean(int i, int j) const;

  // Mean radiance per pixel, the lens flip undone (image pixel (x, y) = cell (W-1-x, H-1-y)), with
  // the AOV layers `layout` describes (its channels must be the sensor's).
  Image developImage(const AovLayout& layout = AovLayout()) const;

  // The sensor's exact state as bytes (native little-endian doubles), and back: a restored
  // sensor continues to accumulate bit for bit as if it had never been saved. deserialize
  // throws std::runtime_error on bytes that are not a sensor.
  std::string serialize() const;
  static Sensor deserialize(const std::string& bytes);

  // Bytes of frame-sized memory held (farm/memory_estimate.h: kSensorBytesPerCell a cell).
  uint64_t memoryBytes() const {
    return sums_.capacity() * sizeof(CompensatedSum) + samples_.capacity() * sizeof(uint64_t);
  }

 private:
  void addCounts(const SensorBuffer& unit);
  int width_, height_, channels_;
  std::vector<CompensatedSum> sums_;  // channels_ per cell
  // Samples per cell. Units cover the whole frame, so every cell holds the same count: one number
  // while that holds (always, in a job), per-cell counts (8 bytes a cell) only once a buffer gave
  // cells different counts.
  uint64_t uniformSamples_ = 0;
  std::vector<uint64_t> samples_;  // empty while the count is uniform
  uint64_t totalSamples_ = 0;
};

}  // namespace lensfarm
