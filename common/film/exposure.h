#pragma once
// From linear radiance to a viewable 8-bit sRGB picture.
//
// Automatic exposure (seed §4.7.4): every pixel is divided by the average per-cell intensity,
// so the image is never over- or under-exposed however long it rendered. Intensity here is
// luminance (Rec. 709). Then the EV compensation (x 2^EV), a tone map (clamp, or Reinhard
// x / (1 + x) per channel), and the sRGB transfer function.
#include <array>
#include <cstdint>
#include <vector>

#include "film/sensor.h"
#include "scene/scene.h"

namespace lensfarm {

// The factor that maps the image's mean luminance to 1 (1 for a black image).
double autoExposureScale(const Image& image);

// 8-bit sRGB, 3 bytes per pixel, row 0 at the top.
std::vector<uint8_t> exposeToSrgb8(const Image& image, const ExposureSettings& settings);

// The sRGB opto-electronic transfer function, for x in [0, 1].
float linearToSrgb(float x);

// The 8-bit sRGB code of a linear value v >= 0 (clamped to [0, 1]): round(255 linearToSrgb(v)).
uint8_t srgb8(float v);

// srgb8 without its pow, the same bytes about 4x faster. srgb8 never decreases as v grows (checked
// for all 1 065 353 217 floats in [0, 1]: docs/performance.md "Everything around the render"), so
// it is fixed by the least float of each of its 255 steps, found once by binary search over float
// bit patterns with srgb8 itself. A value's code is then its bucket's (floats sharing their top
// 17 bits, 2^15 floats a bucket; 32 KB of codes for [0, 1]) plus one if it is at or above the next
// step: no bucket holds two steps (the constructor checks it). tests/film compare the two on the
// floats around every step and on a sample of the rest.
class Srgb8Quantizer {
 public:
  static const Srgb8Quantizer& instance();
  uint8_t operator()(float v) const;  // = srgb8(v) for v >= 0; 0 for v <= 0 and NaN
  const std::array<float, 256>& thresholds() const { return thresholds_; }

 private:
  static constexpr int kBucketShift = 15;
  Srgb8Quantizer();
  std::array<float, 256> thresholds_;  // thresholds_[i - 1]: the least float whose code is i; [255] = inf
  std::vector<uint8_t> bucketCodes_;   // the code of each bucket's least float
};

}  // namespace lensfarm
