#pragma once
// A point-spread function applied to a developed image (film/diffraction_psf.h): each channel of
// the linear image convolved with its own kernel,
//     out(x) = sum_d K(d) in(x - d),
// zero outside the frame (light from beyond the frame is not rendered; light spread past its
// edges leaves it). The kernel sums to 1, so an image whose light stays in the frame keeps its
// total exactly up to rounding. By FFT (math/real_fft2d.h) on a grid padded by the kernel's
// width on every side so that nothing wraps around; values below 0 (rounding, about 1e-16 of the
// brightest) are set to 0.
#include "common/film/diffraction_psf.h"
#include "common/film/image.h"

namespace lensfarm {

void convolveChannels(Image& image, const DiffractionKernel& kernel);

// Where every developed image passes (coordinator/Coordinator::image, for `lensfarm render`, the
// farm's downloads and snapshots alike): the scene's diffraction, or nothing without one.
inline void applyDiffraction(const DiffractionKernel* kernel, Image& image) {
  if (kernel) convolveChannels(image, *kernel);
}

}  // namespace lensfarm
