#include "common/film/sensor.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace lensfarm {

Sensor::Sensor(int width, int height, int channels)
    : width_(width), height_(height), channels_(channels), sums_(size_t(width) * height * size_t(channels)) {}

void Sensor::add(const SensorBuffer& unit) {
  if (unit.width != width_ || unit.height != height_ || unit.samples.size() != unit.cells() ||
      unit.sums.size() != sums_.size())
    throw std::invalid_argument("Sensor::add: buffer size differs from the sensor's");
  for (size_t k = 0; k < sums_.size(); ++k) sums_[k].add(unit.sums[k]);
  addCounts(unit);
}

void Sensor::add(const SensorBuffer& unit, uint32_t samplesPerCell) {
  if (unit.width != width_ || unit.height != height_ || unit.sums.size() != sums_.size())
    throw std::invalid_argument("Sensor::add: buffer size differs from the sensor's");
  for (size_t k = 0; k < sums_.size(); ++k) sums_[k].add(unit.sums[k]);
  const uint64_t cells = uint64_t(width_) * uint64_t(height_);
  if (samples_.empty())
    uniformSamples_ += samplesPerCell;
  else
    for (uint64_t& n : samples_) n += samplesPerCell;
  totalSamples_ += cells * samplesPerCell;
}

void Sensor::add(const SensorBuffer& unit, const SampleMap& counts) {
  if (unit.width != width_ || unit.height != height_ || unit.sums.size() != sums_.size() ||
      !counts.whyNotFor(width_, height_).empty())
    throw std::invalid_argument("Sensor::add: buffer or sample map size differs from the sensor's");
  for (size_t k = 0; k < sums_.size(); ++k) sums_[k].add(unit.sums[k]);
  if (samples_.empty()) samples_.assign(size_t(width_) * size_t(height_), uniformSamples_);
  for (int j = 0; j < height_; ++j)
    for (int i = 0; i < width_; ++i) {
      const uint32_t n = counts.countAt(i, j);
      samples_[size_t(j) * size_t(width_) + size_t(i)] += n;
      totalSamples_ += n;
    }
}

void Sensor::addCounts(const SensorBuffer& unit) {
  const size_t cells = unit.cells();
  const bool uniform = samples_.empty() && std::all_of(unit.samples.begin(), unit.samples.end(),
                                                       [&](uint32_t n) { return n == unit.samples[0]; });
  if (uniform) {
    const uint64_t n = cells ? unit.samples[0] : 0;
    uniformSamples_ += n;
    totalSamples_ += n * cells;
    return;
  }
  if (samples_.empty()) samples_.assign(cells, uniformSamples_);
  for (size_t c = 0; c < cells; ++c) {
    samples_[c] += unit.samples[c];
    totalSamples_ += unit.samples[c];
  }
}

DVec3 Sensor::mean(int i, int j) const {
  const uint64_t n = samples(i, j);
  if (n == 0) return DVec3(0.0);
  const size_t c = (size_t(j) * width_ + i) * size_t(channels_);
  const double inv = 1.0 / double(n);
  return DVec3(sums_[c].value(), sums_[c + 1].value(), sums_[c + 2].value()) * inv;
}

Image Sensor::developImage(const AovLayout& layout) const {
  if (layout.channels != channels_)
    throw std::invalid_argument("Sensor::developImage: the AOV layout is not the sensor's");
  Image image{width_, height_, std::vector<float>(size_t(width_) * height_ * 3)};
  if (layout.any()) image.layers = aovLayers(layout, width_, height_);
  // Each pixel is its own cell's mean: rows in parallel give the same bits for any thread count.
  tbb::parallel_for(tbb::blocked_range<int>(0, height_, 16), [&](const tbb::blocked_range<int>& rows) {
    std::vector<double> cell(static_cast<size_t>(channels_));
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < width_; ++x) {
        const int i = width_ - 1 - x, j = height_ - 1 - y;  // 2013 report §4.7: the lens flips both axes
        const DVec3 m = mean(i, j);
        const size_t pixel = size_t(y) * width_ + x, k = 3 * pixel;
        image.rgb[k] = float(m.x);
        image.rgb[k + 1] = float(m.y);
        image.rgb[k + 2] = float(m.z);
        if (!layout.any()) continue;
        const size_t at = (size_t(j) * width_ + i) * size_t(channels_);
        for (size_t v = 0; v < cell.size(); ++v) cell[v] = sums_[at + v].value();
        developAovPixel(layout, cell.data(), samples(i, j), pixel, image.layers);
      }
    }
  });
  return image;
}

namespace {
// Version 1 held 3 sums a cell; version 2 names its channels after the size.
constexpr char kMagic[8] = {'L', 'F', 'S', 'E', 'N', 'S', '1', '\0'};
constexpr char kMagic2[8] = {'L', 'F', 'S', 'E', 'N', 'S', '2', '\0'};

template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
T take(const std::string& in, size_t& offset) {
  if (offset + sizeof(T) > in.size()) throw std::runtime_error("sensor checkpoint is truncated");
  T v;
  std::memcpy(&v, in.data() + offset, sizeof v);
  offset += sizeof v;
  return v;
}
}  // namespace

std::string Sensor::serialize() const {
  std::string out;
  const size_t cells = size_t(width_) * size_t(height_);
  out.reserve(sizeof kMagic + 16 + sums_.size() * 16 + cells * 8);
  out.append(channels_ == 3 ? kMagic : kMagic2, sizeof kMagic);
  put(out, int32_t(width_));
  put(out, int32_t(height_));
  if (channels_ != 3) put(out, int32_t(channels_));
  put(out, totalSamples_);
  for (const CompensatedSum& s : sums_) {
    put(out, s.runningSum());
    put(out, s.compensation());
  }
  // The file keeps a count per cell (the format predates uniform counts; a checkpoint of either
  // reads back the same).
  if (samples_.empty())
    for (size_t c = 0; c < cells; ++c) put(out, uniformSamples_);
  else
    for (uint64_t n : samples_) put(out, n);
  return out;
}

Sensor Sensor::deserialize(const std::string& bytes) {
  const bool v1 = bytes.size() >= sizeof kMagic && std::memcmp(bytes.data(), kMagic, sizeof kMagic) == 0;
  const bool v2 = bytes.size() >= sizeof kMagic2 && std::memcmp(bytes.data(), kMagic2, sizeof kMagic2) == 0;
  if (!v1 && !v2) throw std::runtime_error("not a lensfarm sensor checkpoint");
  size_t offset = sizeof kMagic;
  const int32_t w = take<int32_t>(bytes, offset), h = take<int32_t>(bytes, offset);
  const int32_t channels = v2 ? take<int32_t>(bytes, offset) : 3;
  if (w <= 0 || h <= 0 || int64_t(w) * h > (int64_t(1) << 28))
    throw std::runtime_error("sensor checkpoint has a bad size");
  if (channels < 3 || channels > 64) throw std::runtime_error("sensor checkpoint has a bad channel count");
  Sensor sensor(w, h, channels);
  sensor.totalSamples_ = take<uint64_t>(bytes, offset);
  const size_t cells = size_t(w) * size_t(h);
  if (bytes.size() != offset + sensor.sums_.size() * 16 + cells * 8)
    throw std::runtime_error("sensor checkpoint has the wrong length");
  for (CompensatedSum& s : sensor.sums_) {
    const double sum = take<double>(bytes, offset);
    s = CompensatedSum::fromState(sum, take<double>(bytes, offset));
  }
  const size_t countsAt = offset;
  sensor.uniformSamples_ = take<uint64_t>(bytes, offset);
  for (size_t c = 1; c < cells; ++c)
    if (take<uint64_t>(bytes, offset) != sensor.uniformSamples_) {
      offset = countsAt;  // counts differ between cells: keep them all
      sensor.samples_.resize(cells);
      for (uint64_t& n : sensor.samples_) n = take<uint64_t>(bytes, offset);
      sensor.uniformSamples_ = 0;
      break;
    }
  return sensor;
}

}  // namespace lensfarm
