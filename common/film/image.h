#pragma once
// A linear RGB image, row-major, row 0 at the top: what a developed sensor gives and what EXR
// and PNG files hold, with the render's other outputs (AOVs, docs/aovs.md) as named layers.
#include <string>
#include <utility>
#include <vector>

#include "common/math/vec.h"

namespace lensfarm {

// A named group of channels beside the beauty: an AOV (albedo, normal, depth, ...). Pixels are
// row-major like the beauty, channels.size() floats each. In an EXR file channel c of layer L is
// "L.c", or plain "c" when L is empty (the OpenEXR standard depth channel "Z").
struct ImageLayer {
  std::string name;
  std::vector<std::string> channels;
  std::vector<float> values;  // channels.size() per pixel

  float at(int x, int y, int width, size_t channel) const {
    return values[(size_t(y) * size_t(width) + size_t(x)) * channels.size() + channel];
  }
  std::string channelName(size_t c) const { return name.empty() ? channels[c] : name + "." + channels[c]; }
};

struct Image {
  Image() = default;
  Image(int w, int h, std::vector<float> pixels) : width(w), height(h), rgb(std::move(pixels)) {}

  int width = 0, height = 0;
  std::vector<float> rgb;          // 3 per pixel
  std::vector<ImageLayer> layers;  // AOVs, in file order; empty for a beauty-only image

  Spectrum at(int x, int y) const {
    const size_t k = 3 * (size_t(y) * width + x);
    return Spectrum(rgb[k], rgb[k + 1], rgb[k + 2]);
  }
  // The layer named `name`, or null.
  const ImageLayer* layer(const std::string& name) const {
    for (const ImageLayer& l : layers)
      if (l.name == name) return &l;
    return nullptr;
  }
};

// The image shrunk by an integer factor so that neither side exceeds maxSide, each pixel the
// mean of the pixels it covers (a box filter, in linear radiance). Unchanged if it already fits.
Image downscaleToFit(const Image& image, int maxSide);

}  // namespace lensfarm
