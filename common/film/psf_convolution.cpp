#include "common/film/psf_convolution.h"

#include <algorithm>

#include "common/math/real_fft2d.h"

namespace lensfarm {

void convolveChannels(Image& image, const DiffractionKernel& kernel) {
  const int w = image.width, h = image.height, r = kernel.radius, side = 2 * r + 1;
  if (w <= 0 || h <= 0) return;
  // Linear convolution is w + 2r wide; a period at least that long keeps the wrapped tail out.
  const int cols = fftFriendlySize(w + 2 * r), rows = fftFriendlySize(h + 2 * r);
  RealFft2d signal(rows, cols), psf(rows, cols);
  const int half = signal.spectrumCols();
  const double scale = 1.0 / (double(rows) * double(cols));
  for (int c = 0; c < 3; ++c) {
    double* in = signal.data();
    std::fill(in, in + size_t(rows) * cols, 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) in[size_t(y) * cols + x] = image.rgb[3 * (size_t(y) * w + x) + c];
    // The kernel with its centre at (0, 0), offsets wrapped.
    double* k = psf.data();
    std::fill(k, k + size_t(rows) * cols, 0.0);
    const std::vector<double>& kc = kernel.channel[size_t(c)];
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx)
        k[size_t((dy + rows) % rows) * cols + size_t((dx + cols) % cols)] = kc[size_t(dy + r) * side + size_t(dx + r)];
    signal.forward();
    psf.forward();
    std::complex<double>* s = signal.spectrum();
    const std::complex<double>* p = psf.spectrum();
    for (size_t i = 0; i < size_t(rows) * half; ++i) s[i] *= p[i] * scale;
    signal.inverse();
    const double* out = signal.data();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        image.rgb[3 * (size_t(y) * w + x) + c] = float(std::max(0.0, out[size_t(y) * cols + x]));
  }
}

}  // namespace lensfarm
