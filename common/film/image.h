#pragma once
// A linear RGB image, row-major, row 0 at the top: what a developed sensor gives and what EXR
// and PNG files hold.
#include <vector>

#include "math/vec.h"

namespace lensfarm {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // 3 per pixel

  Spectrum at(int x, int y) const {
    const size_t k = 3 * (size_t(y) * width + x);
    return Spectrum(rgb[k], rgb[k + 1], rgb[k + 2]);
  }
};

// The image shrunk by an integer factor so that neither side exceeds maxSide, each pixel the
// mean of the pixels it covers (a box filter, in linear radiance). Unchanged if it already fits.
Image downscaleToFit(const Image& image, int maxSide);

}  // namespace lensfarm
