#include "common/film/exposure.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace lensfarm {

namespace {
// Pixel k's Rec. 709 luminance, in double where float would lose it: a pixel near the top of
// single precision (3.4e38) overflows a float sum, a denormal one loses its digits.
double pixelLuminance(const Image& image, size_t k) {
  const float r = image.rgb[3 * k], g = image.rgb[3 * k + 1], b = image.rgb[3 * k + 2];
  const float l = luminance(Spectrum(r, g, b));
  return std::isnormal(l) ? double(l) : 0.2126 * double(r) + 0.7152 * double(g) + 0.0722 * double(b);
}

// The factor that maps `mean` to 1, or 1 where it has none. In double, the mean of a float image
// and its reciprocal are finite and non-zero for any finite image that is not black, from
// denormal pixels (1e-45) to the largest float.
double scaleToOne(double mean) {
  return mean > 0.0 && std::isfinite(mean) && std::isfinite(1.0 / mean) ? 1.0 / mean : 1.0;
}
}  // namespace

double autoExposureScale(const Image& image) {
  double total = 0.0;
  const size_t pixels = size_t(image.width) * image.height;
  for (size_t k = 0; k < pixels; ++k) total += pixelLuminance(image, k);
  return scaleToOne(pixels ? total / double(pixels) : 0.0);
}

double litExposureScale(const Image& image) {
  const int w = image.width, h = image.height;
  std::vector<double> lum(size_t(w) * size_t(h));
  for (size_t k = 0; k < lum.size(); ++k) {
    const double l = pixelLuminance(image, k);
    lum[k] = l > 0.0 && std::isfinite(l) ? l : 0.0;
  }
  // A pixel sees something if it or a neighbour (3 x 3) is not black: a background the camera sees
  // nothing in is black throughout, while a dark, noisy region has light somewhere near every
  // pixel, so it is counted whatever the sample count. Summed in pixel order: the same factor on
  // every machine.
  double total = 0.0;
  size_t lit = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool seen = false;
      for (int dy = -1; dy <= 1 && !seen; ++dy)
        for (int dx = -1; dx <= 1 && !seen; ++dx) {
          const int nx = x + dx, ny = y + dy;
          seen = nx >= 0 && ny >= 0 && nx < w && ny < h && lum[size_t(ny) * w + nx] > 0.0;
        }
      if (!seen) continue;
      total += lum[size_t(y) * w + x];
      ++lit;
    }
  return scaleToOne(lit ? total / double(lit) : 0.0);
}

double exposureScale(const Image& image, ExposureMeter meter) {
  switch (meter) {
    case ExposureMeter::kLit: return litExposureScale(image);
    case ExposureMeter::kMean: return autoExposureScale(image);
    case ExposureMeter::kFixed: return 1.0;
  }
  return 1.0;
}

float linearToSrgb(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

uint8_t srgb8(float v) { return uint8_t(std::lround(linearToSrgb(v) * 255.0f)); }

uint8_t Srgb8Quantizer::operator()(float v) const {
  // Into [0, 1] as linearToSrgb clamps (above 1 is 255, as 1 is); -0, negatives and NaN (which
  // exposeToSrgb8 never passes) to +0, so the bucket index stays inside the table.
  v = v > 0.0f ? std::min(v, 1.0f) : 0.0f;
  const uint8_t code = bucketCodes_[std::bit_cast<uint32_t>(v) >> kBucketShift];
  return uint8_t(code + (v >= thresholds_[code]));  // at most one step inside a bucket
}

Srgb8Quantizer::Srgb8Quantizer() {
  // Non-negative floats order as their bit patterns do: search those between 0 and 1 for the
  // least whose code reaches i.
  for (int i = 1; i <= 255; ++i) {
    uint32_t lo = 0, hi = std::bit_cast<uint32_t>(1.0f);  // srgb8(1) = 255 >= i
    while (lo < hi) {
      const uint32_t mid = lo + (hi - lo) / 2;
      if (srgb8(std::bit_cast<float>(mid)) >= i)
        hi = mid;
      else
        lo = mid + 1;
    }
    thresholds_[size_t(i - 1)] = std::bit_cast<float>(lo);
    // The lookup adds at most one step per bucket: two steps in one bucket would be a wrong code.
    if (i > 1 && std::bit_cast<uint32_t>(thresholds_[size_t(i - 2)]) >> kBucketShift == lo >> kBucketShift)
      throw std::logic_error("Srgb8Quantizer: two sRGB steps in one bucket; lower kBucketShift");
  }
  thresholds_[255] = std::numeric_limits<float>::infinity();  // no step above 255
  bucketCodes_.resize((std::bit_cast<uint32_t>(1.0f) >> kBucketShift) + 1);
  for (size_t b = 0; b < bucketCodes_.size(); ++b)
    bucketCodes_[b] = srgb8(std::bit_cast<float>(uint32_t(b) << kBucketShift));
}

const Srgb8Quantizer& Srgb8Quantizer::instance() {
  static const Srgb8Quantizer quantizer;
  return quantizer;
}

std::vector<uint8_t> exposeToSrgb8(const Image& image, const ExposureSettings& settings) {
  const double scaleD = exposureScale(image, settings.meter) * std::exp2(settings.ev);
  const float scale = float(scaleD);
  // The scale of an image whose mean is below float's normal range (1.2e-38) or near its top
  // (3.4e38), or with a large |ev|, is itself beyond float (Inf, or 0 or a denormal without
  // precision): such images are scaled in double, every other one in float as always.
  const bool inFloat = std::isnormal(scale);
  const Srgb8Quantizer& quantize = Srgb8Quantizer::instance();
  std::vector<uint8_t> out(image.rgb.size());
  // Each byte depends on its own value and the scale alone: the same bytes for any thread count.
  // (The scale's sum above stays in one fixed order, so it too is the same on every machine.)
  tbb::parallel_for(tbb::blocked_range<size_t>(0, image.rgb.size(), size_t(1) << 16),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t k = range.begin(); k < range.end(); ++k) {
                        float v = inFloat ? image.rgb[k] * scale : float(double(image.rgb[k]) * scaleD);
                        // Far above the mean (with a large ev) the product may overflow: white, not NaN.
                        v = std::min(std::max(0.0f, v), std::numeric_limits<float>::max());
                        if (settings.toneMap == ToneMap::kReinhard) v = v / (1.0f + v);
                        out[k] = quantize(v);  // = srgb8(v), without its pow
                      }
                    });
  return out;
}

}  // namespace lensfarm
