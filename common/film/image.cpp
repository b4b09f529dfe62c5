#include "common/film/image.h"

#include <algorithm>

namespace lensfarm {

Image downscaleToFit(const Image& image, int maxSide) {
  const int side = std::max(image.width, image.height);
  if (maxSide <= 0 || side <= maxSide) return image;
  const int factor = (side + maxSide - 1) / maxSide;
  Image out;
  out.width = (image.width + factor - 1) / factor;
  out.height = (image.height + factor - 1) / factor;
  out.rgb.assign(size_t(out.width) * out.height * 3, 0.0f);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      double sum[3] = {0, 0, 0};
      int n = 0;
      for (int yy = y * factor; yy < std::min(image.height, (y + 1) * factor); ++yy)
        for (int xx = x * factor; xx < std::min(image.width, (x + 1) * factor); ++xx, ++n)
          for (int c = 0; c < 3; ++c) sum[c] += image.rgb[3 * (size_t(yy) * image.width + xx) + c];
      for (int c = 0; c < 3; ++c) out.rgb[3 * (size_t(y) * out.width + x) + c] = float(sum[c] / n);
    }
  }
  return out;
}

}  // namespace lensfarm
