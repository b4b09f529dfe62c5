#include "film/sensor.h"

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

}  // namespace lensfarm
