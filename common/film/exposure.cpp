#include "film/exposure.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfarm {

double autoExposureScale(const Image& image) {
  double total = 0.0;
  const size_t pixels = size_t(image.width) * image.height;
  for (size_t k = 0; k < pixels; ++k) {
    const float r = image.rgb[3 * k], g = image.rgb[3 * k + 1], b = image.rgb[3 * k + 2];
    const float l = luminance(Spectrum(r, g, b));
    // A pixel near the top of single precision (3.4e38) overflows the float sum, a denormal one
    // loses its digits: those in double.
    total += std::isnormal(l) ? double(l) : 0.2126 * double(r) + 0.7152 * double(g) + 0.0722 * double(b);
  }
  // In double, the mean of a float image and its reciprocal are finite and non-zero for any
  // finite image that is not black, from denormal pixels (1e-45) to the largest float.
  const double mean = pixels ? total / double(pixels) : 0.0;
  return mean > 0.0 && std::isfinite(mean) && std::isfinite(1.0 / mean) ? 1.0 / mean : 1.0;
}

float linearToSrgb(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

std::vector<uint8_t> exposeToSrgb8(const Image& image, const ExposureSettings& settings) {
  const double scaleD = autoExposureScale(image) * std::exp2(settings.ev);
  const float scale = float(scaleD);
  // The scale of an image whose mean is below float's normal range (1.2e-38) or near its top
  // (3.4e38), or with a large |ev|, is itself beyond float (Inf, or 0 or a denormal without
  // precision): such images are scaled in double, every other one in float as always.
  const bool inFloat = std::isnormal(scale);
  std::vector<uint8_t> out(image.rgb.size());
  for (size_t k = 0; k < image.rgb.size(); ++k) {
    float v = inFloat ? image.rgb[k] * scale : float(double(image.rgb[k]) * scaleD);
    // Far above the mean (with a large ev) the product may overflow: white, not NaN.
    v = std::min(std::max(0.0f, v), std::numeric_limits<float>::max());
    if (settings.toneMap == ToneMap::kReinhard) v = v / (1.0f + v);
    out[k] = uint8_t(std::lround(linearToSrgb(v) * 255.0f));
  }
  return out;
}

}  // namespace lensfarm
