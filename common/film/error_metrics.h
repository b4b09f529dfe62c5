#pragma once
// How far an image is from a reference image of the same scene (docs/accuracy.md).
//
// The headline measure is the relative RMSE of the linear image:
//     relRMSE = sqrt(mean over pixels and channels of (I - R)^2) / mean over pixels and channels of R,
// a single number that halves when the noise halves, and that does not depend on the scene's
// absolute brightness. Beside it:
//  - relMSE (Rousselle et al. 2011): mean of (I - R)^2 / (R^2 + 0.01), which weighs errors in
//    dark pixels as much as in bright ones;
//  - the mean ratio mean(I) / mean(R): bias (energy lost to a bounce limit, for example);
//  - the worst 1 % of pixels: the 99th percentile over pixels of the per-pixel relative error
//    e_p = (1/3) sum over channels of |I - R| / (R + 0.01 mean(R)), the floor keeping dark pixels
//    from dividing by ~0 (scale-free, unlike relMSE's constant);
//  - the RMSE of the displayed picture: both images exposed automatically (2013 report §4.7.4), tone
//    mapped and encoded as 8-bit sRGB as a PNG preview is, compared in [0, 1] units. This is
//    the error a viewer sees.
#include "common/film/exposure.h"
#include "common/film/image.h"

namespace lensfarm {

struct ImageError {
  double rmse = 0.0;
  double relativeRmse = 0.0;
  double relativeMse = 0.0;
  double meanRatio = 0.0;
  double worstPercentRelative = 0.0;  // the 99th percentile of e_p
  double displayRmse = 0.0;
};

// Throws std::invalid_argument if the sizes differ or the reference is empty.
ImageError compareImages(const Image& image, const Image& reference, const ExposureSettings& exposure = {});

// Mean over pixels and channels.
double meanValue(const Image& image);

}  // namespace lensfarm
