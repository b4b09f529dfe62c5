#include "common/film/error_metrics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/film/exposure.h"

namespace lensfarm {

double meanValue(const Image& image) {
  double sum = 0.0;
  for (float v : image.rgb) sum += v;
  return image.rgb.empty() ? 0.0 : sum / double(image.rgb.size());
}

ImageError compareImages(const Image& image, const Image& reference, const ExposureSettings& exposure) {
  if (image.width != reference.width || image.height != reference.height || image.rgb.size() != reference.rgb.size())
    throw std::invalid_argument("compareImages: the image is " + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + ", the reference " + std::to_string(reference.width) +
                                "x" + std::to_string(reference.height));
  if (reference.rgb.empty()) throw std::invalid_argument("compareImages: empty reference");
  const double n = double(reference.rgb.size());
  double squared = 0.0, relative = 0.0;
  for (size_t k = 0; k < reference.rgb.size(); ++k) {
    const double r = reference.rgb[k], d = double(image.rgb[k]) - r;
    squared += d * d;
    relative += d * d / (r * r + 0.01);
  }
  ImageError e;
  e.rmse = std::sqrt(squared / n);
  const double mean = meanValue(reference);
  e.relativeRmse = mean > 0.0 ? e.rmse / mean : 0.0;
  e.relativeMse = relative / n;
  e.meanRatio = mean > 0.0 ? meanValue(image) / mean : 0.0;

  // The worst 1 % of pixels: the 99th percentile (nearest rank) of the per-pixel relative error.
  const size_t pixels = reference.rgb.size() / 3;
  std::vector<double> perPixel(pixels);
  const double floor = 0.01 * std::max(mean, 0.0) + 1e-30;
  for (size_t p = 0; p < pixels; ++p) {
    double sum = 0.0;
    for (size_t c = 3 * p; c < 3 * p + 3; ++c)
      sum +=
          std::abs(double(image.rgb[c]) - double(reference.rgb[c])) / (std::max(double(reference.rgb[c]), 0.0) + floor);
    perPixel[p] = sum / 3.0;
  }
  const size_t rank = std::min(pixels - 1, size_t(std::ceil(0.99 * double(pixels))) - 1);
  std::nth_element(perPixel.begin(), perPixel.begin() + std::ptrdiff_t(rank), perPixel.end());
  e.worstPercentRelative = perPixel[rank];

  const std::vector<uint8_t> shown = exposeToSrgb8(image, exposure), expected = exposeToSrgb8(reference, exposure);
  double displayed = 0.0;
  for (size_t k = 0; k < shown.size(); ++k) {
    const double d = (double(shown[k]) - double(expected[k])) / 255.0;
    displayed += d * d;
  }
  e.displayRmse = std::sqrt(displayed / double(shown.size()));
  return e;
}

}  // namespace lensfarm
