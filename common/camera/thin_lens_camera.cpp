#include "camera/thin_lens_camera.h"

#include <cmath>
#include <numbers>

#include "math/lanes.h"
#include "math/sampling.h"
#include "util/error.h"

namespace lensfarm {

namespace {
// S2 = f S1 / (S1 - f) explodes as S1 -> f; beyond this magnification the set-up is refused.
constexpr double kMaxImageDistanceOverFocalLength = 1e6;
}  // namespace

ThinLensCamera::ThinLensCamera(const ThinLensParams& p, int width, int height)
    : params_(p), width_(width), height_(height) {
  if (!(p.focalLength > 0.0) || !std::isfinite(p.focalLength))
    throw InputError("focal_length", "must be a finite number > 0");
  if (!(p.sensorWidth > 0.0) || !std::isfinite(p.sensorWidth))
    throw InputError("sensor_width", "must be a finite number > 0");
  if (width <= 0 || height <= 0) throw InputError("resolution", "must be positive");
  if (params_.sensorHeight == 0.0) params_.sensorHeight = p.sensorWidth * height / width;
  if (!(params_.sensorHeight > 0.0) || !std::isfinite(params_.sensorHeight))
    throw InputError("sensor_height", "must be a finite number > 0");
  if (!std::isfinite(p.focusDistance) || p.focusDistance <= p.focalLength)
    throw InputError("focus_distance",
                     "S1 = " + std::to_string(p.focusDistance) + " must exceed the focal length f = " +
                         std::to_string(p.focalLength) + ": a lens cannot focus a subject at or inside f");
  imageDistance_ = p.focalLength * p.focusDistance / (p.focusDistance - p.focalLength);
  if (!std::isfinite(imageDistance_) || imageDistance_ > kMaxImageDistanceOverFocalLength * p.focalLength)
    throw InputError("focus_distance", "S1 is so close to f that the sensor distance S2 = f S1 / (S1 - f) "
                                       "is unbounded; move the subject further away");
  if (std::isnan(p.fNumber) || p.fNumber <= 0.0)
    throw InputError("f_number", "must be > 0 (or \"infinity\" for a pinhole)");
  invImageDistance_ = 1.0 / imageDistance_;
  invFocalLength_ = 1.0 / p.focalLength;
  lensRadius_ = std::isinf(p.fNumber) ? 0.0 : p.focalLength / (2.0 * p.fNumber);

  const Vec3 axis = p.lookAt - p.position;
  if (!(glm::length(axis) > 0.0f)) throw InputError("look_at", "must differ from position");
  forward_ = glm::normalize(axis);
  const Vec3 side = glm::cross(forward_, p.up);
  if (!(glm::length(side) > 1e-6f * glm::length(p.up)))
    throw InputError("up", "must not be parallel to the viewing direction");
  right_ = glm::normalize(side);
  up_ = glm::cross(right_, forward_);
}

namespace {
LENSFARM_LANE_LOOPS void pinholeLanes(const ThinLensCamera& camera, const int* __restrict i, int j,
                                      const float* __restrict u0, const float* __restrict u1,
                                      CameraRayLanes& __restrict rays) {
  for (int k = 0; k < kPacketWidth; ++k) rays.set(k, camera.generatePinholeRay(i[k], j, Vec2(u0[k], u1[k])));
}

LENSFARM_LANE_LOOPS void thinLensLanes(const ThinLensCamera& camera, const int* __restrict i, int j,
                                       const float* __restrict u0, const float* __restrict u1,
                                       const float* __restrict lens0, const float* __restrict lens1,
                                       CameraRayLanes& __restrict rays) {
  for (int k = 0; k < kPacketWidth; ++k)
    rays.set(k, camera.generateRay(i[k], j, Vec2(u0[k], u1[k]), Vec2(lens0[k], lens1[k])));
}
}  // namespace

void ThinLensCamera::generateRays(const int (&i)[kPacketWidth], int j, const float (&u0)[kPacketWidth],
                                  const float (&u1)[kPacketWidth], const float (&lens0)[kPacketWidth],
                                  const float (&lens1)[kPacketWidth], CameraRayLanes& rays) const {
  thinLensLanes(*this, i, j, u0, u1, lens0, lens1, rays);
}

void ThinLensCamera::generatePinholeRays(const int (&i)[kPacketWidth], int j, const float (&u0)[kPacketWidth],
                                         const float (&u1)[kPacketWidth], CameraRayLanes& rays) const {
  pinholeLanes(*this, i, j, u0, u1, rays);
}

double focalLengthFromAngleOfView(double sensorWidth, double angleOfViewDegrees) {
  const double alpha = angleOfViewDegrees * std::numbers::pi / 180.0;
  return sensorWidth / (2.0 * std::tan(alpha / 2.0));
}

}  // namespace lensfarm
