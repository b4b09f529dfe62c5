#include "common/light/environment_map.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "common/math/sampling.h"
#include "common/util/error.h"

namespace lensfarm {
namespace {

constexpr double kPiD = std::numbers::pi;
constexpr float kTwoPi = 2.0f * kPi;
constexpr float kInvTwoPi = 0.5f * kInvPi;
// d omega = sin(theta) d theta d phi, theta = pi v, phi = 2 pi (u - 1/2): d omega = 2 pi^2 sin(theta) du dv.
constexpr float kTwoPiSquared = 2.0f * kPi * kPi;

const char* const kChannelNames[3] = {"red", "green", "blue"};

std::string describe(float value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0.0f ? "infinite (+inf)" : "infinite (-inf)";
  std::ostringstream s;
  s << "negative (" << value << ")";
  return s.str();
}

// The solid angle of a pixel of row j: (2 pi / W) (cos theta_j - cos theta_{j+1}) with
// theta_j = pi j / H, the exact integral of sin(theta) d theta d phi over the pixel.
double pixelSolidAngle(int j, int width, int height) {
  const double t0 = kPiD * double(j) / double(height), t1 = kPiD * double(j + 1) / double(height);
  return (2.0 * kPiD / double(width)) * (std::cos(t0) - std::cos(t1));
}

}  // namespace

std::optional<std::string> EnvironmentMap::validate(const Image& image) {
  if (image.width < 1 || image.height < 1 || image.width > kMaxSide || image.height > kMaxSide) {
    std::ostringstream s;
    s << "the image is " << image.width << " x " << image.height << " pixels; an environment map needs 1 to "
      << kMaxSide << " pixels a side";
    return s.str();
  }
  const size_t expected = 3 * size_t(image.width) * size_t(image.height);
  if (image.rgb.size() != expected) {
    std::ostringstream s;
    s << "the image has " << image.rgb.size() << " values for " << image.width << " x " << image.height
      << " RGB pixels (expected " << expected << ")";
    return s.str();
  }
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float value = image.rgb[3 * (size_t(y) * size_t(image.width) + size_t(x)) + size_t(c)];
        if (std::isfinite(value) && value >= 0.0f) continue;
        std::ostringstream s;
        s << "pixel (" << x << ", " << y << ") " << kChannelNames[c] << " is " << describe(value);
        return s.str();
      }
  return std::nullopt;
}

EnvironmentMap EnvironmentMap::fromImage(const Image& image, float strength, float rotationDegrees) {
  if (auto problem = validate(image)) throw InputError("environment", *problem);
  if (!(std::isfinite(strength) && strength >= 0.0f)) {
    std::ostringstream s;
    s << "strength " << strength << " must be finite and non-negative";
    throw InputError("environment", s.str());
  }
  if (!std::isfinite(rotationDegrees)) throw InputError("environment", "rotation must be a finite number of degrees");

  EnvironmentMap map;
  map.width_ = image.width;
  map.height_ = image.height;
  const double alpha = double(rotationDegrees) * kPiD / 180.0;
  map.cosRotation_ = float(std::cos(alpha));
  map.sinRotation_ = float(std::sin(alpha));

  const size_t w = size_t(image.width), h = size_t(image.height);
  map.pixels_.resize(w * h);
  // The sampling weight of pixel (i, j): its luminance times its solid angle over (2 pi^2 / (W H))
  // (the mean of sin(theta) over its row), so that a pixel's probability is its share of
  // the integral of luminance over the sphere. pbrt takes sin(theta) at the pixel's centre;
  // the mean is exact for the piecewise-constant radiance eval() returns, also in the polar rows.
  std::vector<float> weights(w * h);
  DVec3 integral(0.0);
  for (size_t j = 0; j < h; ++j) {
    const double solidAngle = pixelSolidAngle(int(j), image.width, image.height);
    const float meanSin = float(solidAngle * double(w * h) / (2.0 * kPiD * kPiD));
    DVec3 rowSum(0.0);
    for (size_t i = 0; i < w; ++i) {
      const size_t k = j * w + i;
      const Spectrum l = strength * image.at(int(i), int(j));
      if (!isFinite(l)) {
        std::ostringstream s;
        s << "strength " << strength << " times pixel (" << i << ", " << j << ") overflows";
        throw InputError("environment", s.str());
      }
      map.pixels_[k] = l;
      weights[k] = luminance(l) * meanSin;
      rowSum += DVec3(l);
    }
    integral += rowSum * solidAngle;
  }
  map.integral_ = integral;
  map.distribution_.emplace(weights, image.width, image.height);
  return map;
}

EnvironmentMap EnvironmentMap::constant(Spectrum radiance) {
  if (!(isFinite(radiance) && radiance.r >= 0.0f && radiance.g >= 0.0f && radiance.b >= 0.0f)) {
    std::ostringstream s;
    s << "radiance (" << radiance.r << ", " << radiance.g << ", " << radiance.b
      << ") must be finite and non-negative in every channel";
    throw InputError("environment", s.str());
  }
  EnvironmentMap map;
  map.constant_ = radiance;
  map.integral_ = 4.0 * kPiD * DVec3(radiance);
  return map;
}

Vec2 EnvironmentMap::directionToUv(const Vec3& d) {
  const float phi = std::atan2(d.x, -d.z);                                // in [-pi, pi]
  const float theta = std::atan2(std::sqrt(d.x * d.x + d.z * d.z), d.y);  // in [0, pi]
  // phi = +pi and -pi are the same seam (u = 1 == 0). A u that rounds to 1 came from just left
  // of the seam, so it stays in the last column rather than wrapping to the first.
  const float u = std::clamp(0.5f + phi * kInvTwoPi, 0.0f, 0x1.fffffep-1f);
  return Vec2(u, std::min(theta * kInvPi, 1.0f));
}

Vec3 EnvironmentMap::uvToDirection(Vec2 uv) {
  const float theta = kPi * uv.y, phi = kTwoPi * (uv.x - 0.5f);
  const float sinTheta = std::sin(theta);
  return Vec3(sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi));
}

Vec3 EnvironmentMap::toLocal(const Vec3& d) const {
  return Vec3(cosRotation_ * d.x - sinRotation_ * d.z, d.y, sinRotation_ * d.x + cosRotation_ * d.z);
}

Vec3 EnvironmentMap::toWorld(const Vec3& d) const {
  return Vec3(cosRotation_ * d.x + sinRotation_ * d.z, d.y, -sinRotation_ * d.x + cosRotation_ * d.z);
}

size_t EnvironmentMap::pixelOf(Vec2 uv) const {
  return size_t(cellIndex(uv.y, height_)) * size_t(width_) + size_t(cellIndex(uv.x, width_));
}

Spectrum EnvironmentMap::eval(const Vec3& direction) const {
  if (!(glm::dot(direction, direction) > 0.0f)) return Spectrum(0.0f);  // zero or NaN
  if (!distribution_) return constant_;
  return pixels_[pixelOf(directionToUv(toLocal(direction)))];
}

float EnvironmentMap::pdf(const Vec3& direction) const {
  if (!distribution_) return glm::dot(direction, direction) > 0.0f ? 0.25f * kInvPi : 0.0f;
  const Vec3 d = toLocal(direction);
  const float r = std::sqrt(d.x * d.x + d.z * d.z);
  const float sinTheta = r / std::sqrt(r * r + d.y * d.y);
  if (!(sinTheta > 0.0f)) return 0.0f;  // a pole (or zero, or NaN)
  return distribution_->pdf(directionToUv(d)) / (kTwoPiSquared * sinTheta);
}

std::optional<EnvSample> EnvironmentMap::sample(Vec2 u) const {
  if (!distribution_) {
    // Uniform on the sphere (Archimedes: the height y is uniform in [-1, 1]); pdf 1 / (4 pi).
    const float y = 1.0f - 2.0f * u.x;
    const float r = std::sqrt(std::max(0.0f, 1.0f - y * y));
    const float phi = kTwoPi * u.y;
    return EnvSample{Vec3(r * std::cos(phi), y, r * std::sin(phi)), constant_, 0.25f * kInvPi};
  }
  const Vec2 uv = distribution_->sample(u);
  if (!(std::sin(kPi * uv.y) > 0.0f)) return std::nullopt;  // the zenith, v == 0
  const Vec3 wi = toWorld(uvToDirection(uv));
  // Radiance and density are looked up again from wi, so a sample always carries exactly the
  // eval() and pdf() of its own direction (as multiple importance sampling needs). Rounding
  // between uv and wi moves a sample to a neighbouring pixel only within a few ulps of an edge.
  const float density = pdf(wi);
  if (!(density > 0.0f)) return std::nullopt;
  return EnvSample{wi, eval(wi), density};
}

float EnvironmentMap::integralLuminance() const {
  return float(0.2126 * integral_.x + 0.7152 * integral_.y + 0.0722 * integral_.z);
}

}  // namespace lensfarm
