#include "common/camera/thin_lens_camera.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>

#include "common/math/lanes.h"
#include "common/math/sampling.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
// S2 = f S1 / (S1 - f) explodes as S1 -> f; beyond this magnification the set-up is refused.
constexpr double kMaxImageDistanceOverFocalLength = 1e6;
}  // namespace

namespace {
bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string show(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string show(const DVec3& v) { return "[" + show(v.x) + ", " + show(v.y) + ", " + show(v.z) + "]"; }

// A field of view wider than this (the largest angle_of_view) is a unit mix-up, not a camera.
constexpr double kMaxFieldOfViewDegrees = 179.999;
// ... and one narrower than this (the smallest angle_of_view) shows one colour: every cell
// would look along the same direction in single precision.
constexpr double kMinFieldOfViewDegrees = 1e-6;

// A camera ray the kernel can trace: finite, with its origin where Embree accepts one (it
// asserts that every component is within 1.844e18; kMaxRayOriginDistance leaves a margin).
bool traceable(const CameraRay& ray) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(ray.direction[k]) || !(std::abs(ray.origin[k]) <= kMaxRayOriginDistance)) return false;
  return std::abs(glm::length(ray.direction) - 1.0f) < 1e-5f;
}
}  // namespace

ThinLensCamera::ThinLensCamera(const ThinLensParams& p, int width, int height)
    : params_(p), width_(width), height_(height) {
  // The frame first: with look_at at position even the focus distance is undefined.
  if (!finite(p.position)) throw InputError("position", "must be three finite numbers");
  if (!finite(p.lookAt)) throw InputError("look_at", "must be three finite numbers");
  if (!finite(p.up)) throw InputError("up", "must be three finite numbers");
  const DVec3 axisD = DVec3(p.lookAt) - DVec3(p.position);
  if (axisD == DVec3(0.0))
    throw InputError("look_at",
                     "equals camera.position " + show(DVec3(p.position)) + ": the view direction is undefined");
  const Vec3 axis = p.lookAt - p.position;
  if (!finite(axis) || !(glm::length(axis) > 0.0f))
    throw InputError(
        "look_at",
        "is too far from (or too close to) camera.position for single precision: look_at - position = " + show(axisD));
  if (DVec3(p.up) == DVec3(0.0)) throw InputError("up", "must not be [0, 0, 0]: it says which way is up in the image");
  const DVec3 sideD = glm::cross(glm::normalize(axisD), glm::normalize(DVec3(p.up)));
  if (!(glm::length(sideD) > 1e-6))
    throw InputError("up", show(DVec3(p.up)) +
                               " is parallel to the view direction look_at - position = " + show(axisD) +
                               ": the image's up is undefined; give an up that is not along the view direction");

  if (p.angleOfView == 0.0 && (!(p.focalLength > 0.0) || !std::isfinite(p.focalLength)))
    throw InputError("focal_length", "must be a finite number > 0");
  if (!(p.sensorWidth > 0.0) || !(p.sensorWidth <= std::numeric_limits<float>::max()))
    throw InputError("sensor_width", "must be a finite number > 0 (within single precision)");
  if (width <= 0 || height <= 0) throw InputError("resolution", "must be positive");
  if (!(p.sensorHeight >= 0.0) || !(p.sensorHeight <= std::numeric_limits<float>::max()))
    throw InputError("sensor_height", "must be a finite number >= 0 (0: sensor_width * H / W, square cells)");
  if (params_.sensorHeight == 0.0) {
    params_.sensorHeight = p.sensorWidth * height / width;
    if (!(params_.sensorHeight > 0.0))
      throw InputError("sensor_width", show(p.sensorWidth) +
                                           " is too small: the derived sensor_height (sensor_width * H / W) "
                                           "underflows to 0");
  }
  if (!(params_.sensorHeight > 0.0) || !(params_.sensorHeight <= std::numeric_limits<float>::max()))
    throw InputError("sensor_height", "must be a finite number > 0");
  if (p.angleOfView != 0.0) {
    if (!(p.angleOfView >= kMinFieldOfViewDegrees && p.angleOfView <= kMaxFieldOfViewDegrees))
      throw InputError("angle_of_view", "must be in [" + show(kMinFieldOfViewDegrees) + ", " +
                                            show(kMaxFieldOfViewDegrees) + "] degrees, got " + show(p.angleOfView));
    params_.focalLength =
        focalLengthFromAngleOfView(sensorExtent(params_.sensorWidth, params_.sensorHeight, p.fovAxis), p.angleOfView);
    if (!(params_.focalLength > 0.0) || !std::isfinite(params_.focalLength))
      throw InputError("angle_of_view", show(p.angleOfView) + " degrees gives no finite focal length on this sensor");
  }
  const double f = params_.focalLength;
  if (!(p.focusDistance > 0.0) || std::isnan(p.focusDistance))
    throw InputError("focus_distance", "must be a number > 0 (a distance in front of the lens), or infinity");
  if (p.focusDistance <= f)
    throw InputError("focus_distance", "S1 = " + show(p.focusDistance) + " must exceed the focal length f = " +
                                           show(f) + ": a lens cannot focus a subject at or inside f");
  imageDistance_ = std::isinf(p.focusDistance) ? f : f * p.focusDistance / (p.focusDistance - f);
  if (!std::isfinite(imageDistance_) || imageDistance_ > kMaxImageDistanceOverFocalLength * f)
    throw InputError("focus_distance",
                     "S1 is so close to f that the sensor distance S2 = f S1 / (S1 - f) "
                     "is unbounded; move the subject further away");
  // N = 1 / (2 NA) for a lens in air, whose numerical aperture NA = sin(half-angle) is at most
  // 1: no lens is faster than f/0.5 (R = f / (2N) <= f). Smaller N would also let the aperture
  // grow without bound (N = 1e-20 put ray origins beyond what Embree accepts: an abort).
  if (!(p.fNumber >= kMinFNumber))
    throw InputError("f_number", "N = " + show(p.fNumber) + " is below " + show(kMinFNumber) +
                                     ", the smallest f-number a lens in air can have (N = 1 / (2 NA) with numerical "
                                     "aperture NA <= 1); give N >= 0.5, or \"infinity\" for a pinhole");
  invImageDistance_ = 1.0 / imageDistance_;
  invFocalLength_ = 1.0 / f;
  lensRadius_ = std::isinf(p.fNumber) ? 0.0 : f / (2.0 * p.fNumber);
  aperture_ = Aperture(ApertureSpec{p.apertureBlades, p.apertureRotation, p.apertureCurvature, p.apertureImage});
  const double cellArea = (params_.sensorWidth / width) * (params_.sensorHeight / height);
  importance_ = double(aperture_.weight()) * imageDistance_ * imageDistance_ / cellArea;
  if (p.apertureImage && std::isinf(p.fNumber))
    throw InputError("aperture_image", "needs a finite f_number: the image covers a square of side f / N");
  if (!std::isfinite(invImageDistance_) || !std::isfinite(invFocalLength_) || !(invImageDistance_ > 0.0) ||
      !(invFocalLength_ > 0.0))
    throw InputError("focal_length", "f = " + show(f) + " (S2 = " + show(imageDistance_) +
                                         ") has no finite reciprocal in double precision");
  if (!(lensRadius_ <= kMaxRayOriginDistance))
    throw InputError("f_number", "N = " + show(p.fNumber) + " makes the lens radius R = f / (2N) = " +
                                     show(lensRadius_) + ", beyond " + show(kMaxRayOriginDistance) +
                                     ": camera rays would start farther from the camera than the ray tracer accepts; "
                                     "give a larger N or a shorter focal_length");

  // A field of view of 180 degrees or more has no image; it comes from mixed units.
  const double maxHalfTan = std::tan(kMaxFieldOfViewDegrees / 2.0 * std::numbers::pi / 180.0);
  const double minHalfTan = std::tan(kMinFieldOfViewDegrees / 2.0 * std::numbers::pi / 180.0);
  for (const auto& [field, size] : {std::pair<const char*, double>{"sensor_width", params_.sensorWidth},
                                    std::pair<const char*, double>{"sensor_height", params_.sensorHeight}}) {
    if (!(size / (2.0 * imageDistance_) <= maxHalfTan))
      throw InputError(field, show(size) + " at S2 = " + show(imageDistance_) +
                                  " behind the lens gives a field of view of 180 degrees or more (at most " +
                                  show(kMaxFieldOfViewDegrees) +
                                  "): the sensor size and focal_length must be in the same unit");
    if (!(size / (2.0 * imageDistance_) >= minHalfTan))
      throw InputError(field, show(size) + " at S2 = " + show(imageDistance_) +
                                  " behind the lens gives a field of view of " +
                                  show(2.0 * std::atan(size / (2.0 * imageDistance_)) * 180.0 / std::numbers::pi) +
                                  " degrees, below " + show(kMinFieldOfViewDegrees) +
                                  " (the smallest angle_of_view): every pixel would see the same direction in single "
                                  "precision; the sensor size and focal_length must be in the same unit");
  }

  forward_ = glm::normalize(axis);
  const Vec3 side = glm::cross(forward_, p.up);
  if (!(glm::length(side) > 1e-6f * glm::length(p.up)))
    throw InputError("up", "must not be parallel to the viewing direction");
  right_ = glm::normalize(side);
  up_ = glm::cross(right_, forward_);

  // What reaches the kernel: the rays through the sensor's corners and centre, through the lens
  // centre and the rim of the aperture, are finite and start where Embree accepts a ray. The
  // checks above should make this hold; this is the guarantee that no NaN, Inf or out-of-range
  // origin is ever traced, whatever combination of extremes got through them.
  if (!traceable(generatePinholeRay(width / 2, height / 2, Vec2(0.5f))))
    throw InputError("position", "gives camera rays the ray tracer cannot trace (an origin beyond " +
                                     show(kMaxRayOriginDistance) + " or a non-finite direction)");
  const float uMax = 0x1.fffffep-1f;  // the largest sample value below 1
  for (const int i : {0, width - 1})
    for (const int j : {0, height - 1})
      for (const Vec2 uSensor : {Vec2(0.0f), Vec2(uMax)}) {
        if (!traceable(generatePinholeRay(i, j, uSensor)))
          throw InputError("sensor_width", "gives camera rays with a non-finite direction at the sensor's corners");
        for (const Vec2 uLens : {Vec2(0.0f, 0.5f), Vec2(uMax, 0.5f), Vec2(0.5f, 0.0f), Vec2(0.5f, uMax)})
          if (!traceable(generateRay(i, j, uSensor, uLens)))
            throw InputError("f_number", "N = " + show(p.fNumber) + " (lens radius R = " + show(lensRadius_) +
                                             ") gives camera rays the ray tracer cannot trace at the aperture's rim");
      }
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
  // The round aperture's loop as it always was; a shaped one only for a scene that asks for it.
  const float r = float(camera.lensRadius());
  if (camera.aperture().isRound()) {
    for (int k = 0; k < kPacketWidth; ++k)
      rays.set(k, camera.rayThrough(camera.sensorPoint(i[k], j, Vec2(u0[k], u1[k])),
                                    sampleConcentricDisk(Vec2(lens0[k], lens1[k])) * r));
  } else {
    for (int k = 0; k < kPacketWidth; ++k)
      rays.set(k, camera.generateRay(i[k], j, Vec2(u0[k], u1[k]), Vec2(lens0[k], lens1[k])));
  }
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

void ThinLensCamera::sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const {
  generateRays(s.column, s.row, s.u0, s.u1, s.lens0, s.lens1, rays);
  std::fill(std::begin(weight), std::end(weight), aperture_.weight());
}

std::optional<CameraConnection> ThinLensCamera::connectThrough(const Vec3& p, Vec2 r) const {
  CameraConnection c;
  c.lensPoint = params_.position + r.x * right_ + r.y * up_;
  const Vec3 toLens = c.lensPoint - p;
  c.distance2 = glm::dot(toLens, toLens);
  if (!(c.distance2 > 0.0f)) return std::nullopt;
  c.distance = std::sqrt(c.distance2);
  c.toLens = toLens / c.distance;
  // rayThrough inverted: the ray from r in direction w = -toLens left sensor point
  //     s = r - S2 (n2 + r / f),  n2 = w / (w . forward)  (the 2013 report's eq. 1, solved for s).
  const Vec3 w = -c.toLens;
  const double cosTheta = glm::dot(w, forward_);
  if (!(cosTheta > 0.0)) return std::nullopt;
  const double n2x = glm::dot(w, right_) / cosTheta, n2y = glm::dot(w, up_) / cosTheta;
  const double sx = r.x - imageDistance_ * (n2x + r.x * invFocalLength_),
               sy = r.y - imageDistance_ * (n2y + r.y * invFocalLength_);
  const double fi = std::floor((sx / params_.sensorWidth + 0.5) * width_),
               fj = std::floor((0.5 - sy / params_.sensorHeight) * height_);
  if (!(fi >= 0.0 && fi < width_ && fj >= 0.0 && fj < height_)) return std::nullopt;
  c.cell = uint64_t(fj) * uint64_t(width_) + uint64_t(fi);
  c.importance = importance_ / (cosTheta * cosTheta * cosTheta);
  return c;
}

ExitPupil ThinLensCamera::exitPupil() const { return ExitPupil{aperture_, imageDistance_ / (2.0 * lensRadius_)}; }

double focalLengthFromAngleOfView(double sensorExtent, double angleOfViewDegrees) {
  const double alpha = angleOfViewDegrees * std::numbers::pi / 180.0;
  return sensorExtent / (2.0 * std::tan(alpha / 2.0));
}

const char* fovAxisName(FovAxis axis) {
  switch (axis) {
    case FovAxis::kHorizontal: return "horizontal";
    case FovAxis::kVertical: return "vertical";
    case FovAxis::kDiagonal: return "diagonal";
    case FovAxis::kSmaller: return "smaller";
    case FovAxis::kLarger: return "larger";
  }
  return "horizontal";
}

double sensorExtent(double sensorWidth, double sensorHeight, FovAxis axis) {
  switch (axis) {
    case FovAxis::kHorizontal: return sensorWidth;
    case FovAxis::kVertical: return sensorHeight;
    case FovAxis::kDiagonal: return std::hypot(sensorWidth, sensorHeight);
    case FovAxis::kSmaller: return std::min(sensorWidth, sensorHeight);
    case FovAxis::kLarger: return std::max(sensorWidth, sensorHeight);
  }
  return sensorWidth;
}

double angleOfViewDegrees(double sensorExtent, double imageDistance) {
  return 2.0 * std::atan(sensorExtent / (2.0 * imageDistance)) * 180.0 / std::numbers::pi;
}

}  // namespace lensfarm
