#include "film/exposure.h"

#include <algorithm>
#include <cmath>

namespace lensfarm {

double autoExposureScale(const Image& image) {
  double total = 0.0;
  const size_t pixels = size_t(image.width) * image.height;
  for (size_t k = 0; k < pixels; ++k)
    total += luminance(Spectrum(image.rgb[3 * k], image.rgb[3 * k + 1], image.rgb[3 * k + 2]));
  const double mean = pixels ? total / double(pixels) : 0.0;
  return mean > 0.0 && std::isfinite(mean) ? 1.0 / mean : 1.0;
}

float linearToSrgb(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

std::vector<uint8_t> exposeToSrgb8(const Image& image, const ExposureSettings& settings) {
  const float scale = float(autoExposureScale(image) * std::exp2(settings.ev));
  std::vector<uint8_t> out(image.rgb.size());
  for (size_t k = 0; k < image.rgb.size(); ++k) {
    float v = std::max(0.0f, image.rgb[k] * scale);
    if (settings.toneMap == ToneMap::kReinhard) v = v / (1.0f + v);
    out[k] = uint8_t(std::lround(linearToSrgb(v) * 255.0f));
  }
  return out;
}

}  // namespace lensfarm
