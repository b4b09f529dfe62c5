#pragma once
// From linear radiance to a viewable 8-bit sRGB picture.
//
// Automatic exposure scales every pixel by one factor, chosen by the meter (ExposureMeter,
// below), so the image is never over- or under-exposed however long it rendered:
//  - lit (the default): the mean luminance of the pixels that see something maps to 1, a pixel
//    seeing something when it or a neighbour is not black. A black background (every model
//    exported without a world) is left out instead of pulling the exposure up, and, being a mean,
//    the factor does not drift with the noise of a progressive image (a log-average or a median
//    of noisy pixels does: measured, docs/scene-format.md "render.exposure");
//  - mean (the 2013 report's, §4.7.4): every pixel is divided by the mean luminance of all pixels;
//  - fixed: no automatic factor.
// Luminance is Rec. 709's. Then the EV compensation (x 2^EV), a tone map (clamp, or Reinhard
// x / (1 + x) per channel), and the sRGB transfer function.
#include <array>
#include <cstdint>
#include <vector>

#include "common/film/sensor.h"

namespace lensfarm {

enum class ToneMap { kClamp, kReinhard };

// How the automatic exposure meters an image (below): kLit maps the mean luminance of
// the pixels that see something to 1, so a black background does not blow out what stands in
// front of it; kMean maps the mean luminance of every pixel to 1 (the 2013 report's, §4.7.4); kFixed
// applies no automatic scale (the EV alone: the same exposure on every frame of an animation).
enum class ExposureMeter { kLit, kMean, kFixed };

struct ExposureSettings {
  double ev = 0.0;  // compensation applied after the automatic exposure, in stops
  ToneMap toneMap = ToneMap::kReinhard;
  ExposureMeter meter = ExposureMeter::kLit;
};

// The factor that maps the image's mean luminance to 1 (1 for a black image): the mean meter.
double autoExposureScale(const Image& image);

// The factor that maps the mean luminance of the pixels that see something (a pixel or one of
// its 3 x 3 neighbours not black) to 1 (1 for a black image): the lit meter.
double litExposureScale(const Image& image);

// The meter's factor (without the EV).
double exposureScale(const Image& image, ExposureMeter meter);

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
