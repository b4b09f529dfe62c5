#pragma once
// An aperture image (camera/aperture.h owns its convention): a square transmission image in
// [0, 1] over the aperture's bounding square, decoded once per scene load and shared by every
// camera of the scene, with the distribution that samples it in proportion to its transmission.
//
// Transmission of a pixel: a grey pixel's value; an RGB pixel's Rec. 709 luminance; times alpha.
// 8-bit (and 16-bit) values are sRGB encoded, as the project writes its PNGs (film/image_io.h),
// and decoded to linear (texture/image_decode.h); EXR and Radiance HDR values are linear.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/math/distribution.h"

namespace lensfarm {

class ApertureImage {
 public:
  static constexpr int kMaxSide = 4096;  // 128 MiB of sampling tables at most

  // From a file's bytes (PNG, JPEG, EXR or Radiance HDR, told by their bytes). Throws InputError
  // naming `shown` when the file cannot be decoded, is not square, is larger than kMaxSide, has a
  // transmission outside [0, 1] (naming the pixel) or lets no light through.
  static std::shared_ptr<const ApertureImage> decode(const std::string& bytes, const std::string& shown);
  // From transmissions, row-major from the top, `side` x `side`; the same checks.
  static std::shared_ptr<const ApertureImage> fromTransmission(std::vector<float> transmission, int side,
                                                               const std::string& shown);

  int side() const { return side_; }
  const std::string& name() const { return name_; }
  // Pixel (column x from the left, row y from the top).
  float at(int x, int y) const { return transmission_[size_t(y) * size_t(side_) + size_t(x)]; }
  // T, the mean transmission over the square (in double, from the pixels).
  double meanTransmission() const { return mean_; }
  // The largest distance from the square's centre, in half-sides, of a point of a pixel that
  // lets light through (at most sqrt 2).
  double extent() const { return extent_; }
  // Over [0,1)^2 with row 0 at the top, in proportion to the transmission.
  const Distribution2D& distribution() const { return *distribution_; }

 private:
  ApertureImage() = default;
  int side_ = 0;
  std::string name_;
  std::vector<float> transmission_;
  std::optional<Distribution2D> distribution_;
  double mean_ = 0.0, extent_ = 0.0;
};

}  // namespace lensfarm
