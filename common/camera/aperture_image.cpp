#include "common/camera/aperture_image.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/texture/image_decode.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
// A luminance computed in float may land a hair above 1 for white (0.2126 + 0.7152 + 0.0722):
// values this close to the range count as its end.
constexpr double kRangeSlack = 1e-6;
}  // namespace

std::shared_ptr<const ApertureImage> ApertureImage::decode(const std::string& bytes, const std::string& shown) {
  const RgbaImage rgba = decodeImage(bytes, shown, ColorEncoding::kSrgb);
  if (rgba.width != rgba.height)
    throw InputError(shown, "is " + std::to_string(rgba.width) + " x " + std::to_string(rgba.height) +
                                " pixels; an aperture image must be square (it covers the aperture's bounding square)");
  if (rgba.width > kMaxSide)
    throw InputError(shown, "is " + std::to_string(rgba.width) + " pixels wide; an aperture image may be at most " +
                                std::to_string(kMaxSide));
  std::vector<float> t(size_t(rgba.width) * size_t(rgba.height));
  for (size_t k = 0; k < t.size(); ++k) {
    const float* p = &rgba.texels[4 * k];
    // Grey stays exact; colour by its Rec. 709 luminance, in double.
    const double y = (p[0] == p[1] && p[1] == p[2]) ? double(p[0]) : 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    t[k] = float(y * double(p[3]));
  }
  return fromTransmission(std::move(t), rgba.width, shown);
}

std::shared_ptr<const ApertureImage> ApertureImage::fromTransmission(std::vector<float> transmission, int side,
                                                                     const std::string& shown) {
  if (side < 1 || transmission.size() != size_t(side) * size_t(side))
    throw InputError(shown, "an aperture image needs side x side transmissions");
  if (side > kMaxSide)
    throw InputError(shown, "is " + std::to_string(side) + " pixels wide; an aperture image may be at most " +
                                std::to_string(kMaxSide));
  auto image = std::shared_ptr<ApertureImage>(new ApertureImage());
  image->side_ = side;
  image->name_ = shown;
  double sum = 0.0, extent2 = 0.0;
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      float& v = transmission[size_t(y) * size_t(side) + size_t(x)];
      if (!(v >= -kRangeSlack && v <= 1.0 + kRangeSlack)) {
        std::ostringstream s;
        s << "pixel (" << x << ", " << y << ") has transmission " << v
          << "; an aperture image's values (grey, or the luminance of RGB, times alpha) must be in [0, 1]";
        throw InputError(shown, s.str());
      }
      v = std::clamp(v, 0.0f, 1.0f);
      sum += v;
      if (v > 0.0f) {
        // The pixel's corner farthest from the centre, in half-sides.
        const double fx = std::max(std::abs(2.0 * x / side - 1.0), std::abs(2.0 * (x + 1) / side - 1.0));
        const double fy = std::max(std::abs(2.0 * y / side - 1.0), std::abs(2.0 * (y + 1) / side - 1.0));
        extent2 = std::max(extent2, fx * fx + fy * fy);
      }
    }
  if (!(sum > 0.0)) throw InputError(shown, "is black everywhere: an aperture image must let some light through");
  image->mean_ = sum / (double(side) * double(side));
  image->extent_ = std::sqrt(extent2);
  image->transmission_ = std::move(transmission);
  image->distribution_.emplace(image->transmission_, side, side);
  return image;
}

}  // namespace lensfarm
