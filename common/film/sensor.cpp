#include "film/sensor.h"

#include <cstring>
#include <stdexcept>

namespace lensfarm {

Sensor::Sensor(int width, int height)
    : width_(width), height_(height), sums_(size_t(width) * height * 3), samples_(size_t(width) * height, 0) {}

void Sensor::add(const SensorBuffer& unit) {
  if (unit.width != width_ || unit.height != height_)
    throw std::invalid_argument("Sensor::add: buffer size differs from the sensor's");
  for (size_t k = 0; k < sums_.size(); ++k) sums_[k].add(unit.sums[k]);
  for (size_t c = 0; c < samples_.size(); ++c) {
    samples_[c] += unit.samples[c];
    totalSamples_ += unit.samples[c];
  }
}

DVec3 Sensor::mean(int i, int j) const {
  const size_t c = size_t(j) * width_ + i;
  if (samples_[c] == 0) return DVec3(0.0);
  const double inv = 1.0 / double(samples_[c]);
  return DVec3(sums_[3 * c].value(), sums_[3 * c + 1].value(), sums_[3 * c + 2].value()) * inv;
}

Image Sensor::developImage() const {
  Image image{width_, height_, std::vector<float>(size_t(width_) * height_ * 3)};
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const DVec3 m = mean(width_ - 1 - x, height_ - 1 - y);  // seed §4.7: the lens flips both axes
      const size_t k = 3 * (size_t(y) * width_ + x);
      image.rgb[k] = float(m.x);
      image.rgb[k + 1] = float(m.y);
      image.rgb[k + 2] = float(m.z);
    }
  }
  return image;
}

namespace {
constexpr char kMagic[8] = {'L', 'F', 'S', 'E', 'N', 'S', '1', '\0'};

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
  out.reserve(16 + 24 + sums_.size() * 16 + samples_.size() * 8);
  out.append(kMagic, sizeof kMagic);
  put(out, int32_t(width_));
  put(out, int32_t(height_));
  put(out, totalSamples_);
  for (const CompensatedSum& s : sums_) {
    put(out, s.runningSum());
    put(out, s.compensation());
  }
  for (uint64_t n : samples_) put(out, n);
  return out;
}

Sensor Sensor::deserialize(const std::string& bytes) {
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw std::runtime_error("not a lensfarm sensor checkpoint");
  size_t offset = sizeof kMagic;
  const int32_t w = take<int32_t>(bytes, offset), h = take<int32_t>(bytes, offset);
  if (w <= 0 || h <= 0 || int64_t(w) * h > (int64_t(1) << 28)) throw std::runtime_error("sensor checkpoint has a bad size");
  Sensor sensor(w, h);
  sensor.totalSamples_ = take<uint64_t>(bytes, offset);
  if (bytes.size() != offset + sensor.sums_.size() * 16 + sensor.samples_.size() * 8)
    throw std::runtime_error("sensor checkpoint has the wrong length");
  for (CompensatedSum& s : sensor.sums_) {
    const double sum = take<double>(bytes, offset);
    s = CompensatedSum::fromState(sum, take<double>(bytes, offset));
  }
  for (uint64_t& n : sensor.samples_) n = take<uint64_t>(bytes, offset);
  return sensor;
}

}  // namespace lensfarm
