#pragma once
// The environment: an infinitely distant light surrounding the scene, either a constant radiance
// or an equirectangular (latitude-longitude) linear RGB image, importance sampled in proportion
// to each pixel's luminance times its solid angle: pbrt's image infinite light (Pharr, Jakob,
// Humphreys, "Physically Based Rendering", 4th ed. §12.5, which stores an equal-area octahedral
// image; the equirectangular version with its Jacobian is the 3rd edition's InfiniteAreaLight,
// §12.6 and §14.2.4).
//
// Convention (owned here; docs/scene-format.md's Conventions table points here, and the scene's
// "environment" reaches it through light/environment_light.h):
//  - World up is +y. A direction d = (x, y, z) points from the scene towards the sky.
//  - theta = acos(y) is the angle from the zenith (0 straight up, pi straight down);
//    phi = atan2(x, -z) is the azimuth, 0 along -z and +pi/2 along +x.
//  - Image coordinates: u = 0.5 + phi / (2 pi) in [0,1) along a row, left to right;
//    v = theta / pi in [0,1] down the image, row 0 at the top (the zenith), as in
//    film/image.h. So the centre of the image (u = 0.5, v = 0.5) is the horizon along -z, the
//    top row the zenith, the bottom row the nadir, and u = 0.75 the horizon along +x.
//  - Seen from inside (a camera at the origin looking along -z with up +y, whose right is +x),
//    the image reads the right way round, not mirrored: u grows to the right.
//  - Pixel (i, j) of a W x H image covers u in [i/W, (i+1)/W), v in [j/H, (j+1)/H); its solid
//    angle is (2 pi / W) (cos(pi j / H) - cos(pi (j+1) / H)).
//  - rotationDegrees turns the environment about +y by the right-hand rule: counter-clockwise
//    seen from above, so with 90 degrees what was seen along -z is seen along -x (a direction
//    d without rotation becomes R_y(alpha) d, R_y(alpha)(x, y, z) = (x cos a + z sin a, y,
//    -x sin a + z cos a)). Other programs' rotation settings may turn the other way.
//  - strength multiplies every pixel (the radiance stored, returned, integrated).
//
// Lookups are nearest-pixel (no bilinear filtering), so eval() is exactly the piecewise-constant
// function the sampling distribution is built from: within a pixel eval/pdf varies only with
// sin(theta), and a pixel that is black is never sampled.
//
// Memory: 20 bytes per pixel (the radiance, 12, and the sampling cdf in double, 8), so a
// 4096 x 2048 map takes 160 MiB and 8192 x 4096 640 MiB; fromImage needs 4 more per pixel
// while it builds. All methods are const and safe to call from many threads.
#include <optional>
#include <string>
#include <vector>

#include "common/film/image.h"
#include "common/math/distribution.h"
#include "common/math/vec.h"

namespace lensfarm {

struct EnvSample {
  Vec3 wi;            // unit direction towards the environment (world space)
  Spectrum radiance;  // eval(wi)
  float pdf;          // solid-angle density, pdf(wi)
};

class EnvironmentMap {
 public:
  // The largest width and height accepted (validate()).
  static constexpr int kMaxSide = 65536;

  // Why `image` cannot be an environment map, or nothing if it can: an empty or inconsistent
  // size, or a pixel that is NaN, infinite or negative, named by its column x (from the left),
  // row y (from the top) and channel: "pixel (12, 7) red is NaN". The first bad value found,
  // scanning rows from the top. A scene loader prefixes its field: "environment.file: ...".
  static std::optional<std::string> validate(const Image& image);

  // An environment from an equirectangular image (any size from 1 x 1 to kMaxSide per side).
  // Throws InputError (where "environment") with validate()'s message if the image is not
  // valid, or if strength is not finite and >= 0, rotationDegrees is not finite, or a pixel
  // times strength overflows a float.
  static EnvironmentMap fromImage(const Image& image, float strength = 1.0f, float rotationDegrees = 0.0f);
  // The same radiance from every direction; sampled uniformly over the sphere (pdf 1 / 4 pi).
  // Throws InputError (where "environment") unless every channel is finite and >= 0.
  static EnvironmentMap constant(Spectrum radiance);

  bool isConstant() const { return !distribution_.has_value(); }
  // The memory it holds: its pixels and its sampling distribution (8 bytes a pixel).
  uint64_t bytes() const {
    return pixels_.size() * sizeof(Spectrum) +
           (distribution_ ? uint64_t(width_) * uint64_t(height_) * sizeof(double) : 0);
  }
  int width() const { return width_; }    // 0 for a constant environment
  int height() const { return height_; }  // 0 for a constant environment

  // Radiance arriving from direction d (d need not be unit length; black if it is zero or NaN).
  Spectrum eval(const Vec3& direction) const;

  // A direction sampled in proportion to luminance x solid angle (constant: uniformly), with
  // eval() and pdf() of that direction. Nothing for the measure-zero samples at the poles
  // (sin theta == 0, where the solid-angle density is undefined) or where rounding carries the
  // direction into a pixel of zero density.
  std::optional<EnvSample> sample(Vec2 u) const;

  // The solid-angle density with which sample() produces direction d:
  // pdf_uv(u, v) / (2 pi^2 sin theta), the uv density times the Jacobian of the equirectangular
  // map (d omega = sin theta d theta d phi = 2 pi^2 sin theta du dv). 0 at the poles.
  float pdf(const Vec3& direction) const;

  // The integral of the radiance over the sphere, per channel and as luminance, in double from
  // the pixels and their exact solid angles (constant: 4 pi L). For choosing among lights by
  // power: an infinite light's power is pi r^2 times this, r the scene's bounding radius
  // (pbrt-v4 §12.5, the infinite lights' Phi()).
  Spectrum integral() const { return Spectrum(integral_); }
  float integralLuminance() const;

  // The convention above, in the environment's own frame (before rotation): d -> (u, v) with
  // u in [0,1), v in [0,1], and its inverse (a unit direction). d need not be unit length.
  static Vec2 directionToUv(const Vec3& d);
  static Vec3 uvToDirection(Vec2 uv);

 private:
  EnvironmentMap() = default;

  Vec3 toLocal(const Vec3& d) const;  // world -> the image's frame: R_y(-alpha) d
  Vec3 toWorld(const Vec3& d) const;  // R_y(alpha) d
  size_t pixelOf(Vec2 uv) const;      // nearest pixel, the same cells as the distribution

  int width_ = 0, height_ = 0;
  std::vector<Spectrum> pixels_;  // row-major from the top, strength applied
  Spectrum constant_{0.0f};
  std::optional<Distribution2D> distribution_;  // over (u, v); empty for a constant environment
  float cosRotation_ = 1.0f, sinRotation_ = 0.0f;
  DVec3 integral_{0.0};
};

}  // namespace lensfarm
