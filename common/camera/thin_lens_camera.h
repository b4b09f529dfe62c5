#pragma once
// The 2013 report's optical system (§4.1, §4.6): a rectangular sensor behind a thin lens.
//
// Geometry, in the camera frame (right, up, forward; forward is the optical axis):
//  - the lens is a disk of radius R centred on the camera position, perpendicular to the axis;
//  - the sensor is a LW x LH rectangle at distance S2 behind the lens, centred on the axis;
//  - the lens focuses the plane at distance S1 in front of it onto the sensor:
//        1/S1 + 1/S2 = 1/f                                   (report eq. 6)
//  - the aperture follows from the f-number N:  2R = f / N   (report eq. 7); N = inf is a pinhole.
//
// Sensor orientation. Cell (i, j), i in [0, W), j in [0, H), has its centre at
//     x = LW * ((i + 0.5) / W - 0.5) along `right`,  y = LH * (0.5 - (j + 0.5) / H) along `up`.
// A lens forms an inverted image, so the scene's upper right lands on the sensor's lower left:
// cell (i, j) sees what the viewer expects at image pixel (W-1-i, H-1-j). The flip is undone
// once, when a sensor is developed into an image (film/sensor.h), never in the camera.
//
// A camera ray leaves the lens point, so a sample measures the radiance arriving at the sensor
// through the lens; like the report (§4.6.1) every sample carries the same weight (no cos^4
// falloff and no brightness change with N); an aperture image darkens by its mean transmission,
// the weight every sample then carries (camera/aperture.h, "Exposure").
#include <limits>
#include <memory>
#include <string>

#include "common/camera/aperture.h"
#include "common/camera/camera.h"
#include "common/math/lanes.h"
#include "common/math/sampling.h"
#include "common/math/vec.h"

namespace lensfarm {

// The smallest f-number: N = 1 / (2 NA) for a lens in air, whose numerical aperture NA is at most
// 1, so no lens is faster than f/0.5; the aperture radius R = f / (2N) is then at most f.
inline constexpr double kMinFNumber = 0.5;
// How far from the camera a camera ray may start (the aperture radius R at most): Embree asserts
// that every component of a ray origin is within 1.844e18 (its FLT_LARGE) and aborts otherwise.
inline constexpr double kMaxRayOriginDistance = 1e18;

// The image axis an angle of view is measured along (Mitsuba 3's fov_axis): the sensor's width,
// height or diagonal, or the shorter or longer of width and height.
enum class FovAxis { kHorizontal, kVertical, kDiagonal, kSmaller, kLarger };

struct ThinLensParams {
  Vec3 position{0.0f};            // lens centre
  Vec3 lookAt{0.0f, 0.0f, 1.0f};  // defines the optical axis
  Vec3 up{0.0f, 1.0f, 0.0f};      // the sensor's `up` is this, made orthogonal to the axis
  double focalLength = 0.0;       // f
  // An angle of view in degrees along fovAxis, or 0. When set, f is derived from it at the
  // camera's resolution, f = L / (2 tan(a/2)) with L the sensor's extent along the axis (2013
  // report eq. 4), because the sensor's height, and so every axis but the width, follows the image's
  // aspect ratio; focalLength then holds f at the scene's own resolution.
  double angleOfView = 0.0;
  FovAxis fovAxis = FovAxis::kHorizontal;
  // S1, along the axis; infinity focuses at infinity (S2 = f), as a pinhole is: its angle of view
  // is then exactly 2 atan(L / 2f) whatever the distance to look_at.
  double focusDistance = 0.0;
  double sensorWidth = 0.0;                                  // LW
  double sensorHeight = 0.0;                                 // LH; 0 = derived, LW * H / W (square cells)
  double fNumber = std::numeric_limits<double>::infinity();  // N; inf = pinhole
  // The aperture's shape (camera/aperture.h owns the convention): 0 = round; n >= 3 =
  // a regular n-gon of blades inscribed in the radius R = f / (2N), turned `apertureRotation`
  // degrees counter-clockwise from a vertex along `right`, its edges arcs of curvature
  // `apertureCurvature` (0 straight, 1 the circle); or an image over the square of side 2R.
  // Defocused highlights (bokeh) take its shape.
  int apertureBlades = 0;
  double apertureRotation = 0.0;
  double apertureCurvature = 0.0;
  std::shared_ptr<const ApertureImage> apertureImage;
};

class ThinLensCamera : public Camera {
 public:
  // Validates the parameters; throws InputError whose `where` is the offending field name
  // (position, look_at, up, focal_length, sensor_width, sensor_height, focus_distance, f_number).
  // The frame is checked first (look_at == position, a zero up or one parallel to the view
  // direction), then each number: non-finite, zero or negative values, S1 <= f, N below
  // kMinFNumber, a lens radius beyond kMaxRayOriginDistance, a sensor beyond single precision, a
  // field of view of 180 degrees or more or below 1e-6 degrees (mixed units). Last, the rays
  // through the sensor's corners and the aperture's rim must be finite and traceable, so nothing
  // non-finite ever reaches the kernel. The aperture's fields are checked by Aperture (its
  // `where` names aperture_blades, aperture_rotation, aperture_curvature or aperture_image); an
  // aperture image needs a finite f-number.
  ThinLensCamera(const ThinLensParams& params, int width, int height);

  // The ray for a point of sensor cell (i, j) at offset uSensor in [0,1)^2 within the cell,
  // through the lens point at uLens in [0,1)^2 (mapped to the aperture: Aperture::sample). The
  // sample's weight is aperture().weight().
  CameraRay generateRay(int i, int j, Vec2 uSensor, Vec2 uLens) const;

  // The ray through the lens centre: what generateRay gives for a closed aperture, bit for bit.
  CameraRay generatePinholeRay(int i, int j, Vec2 uSensor) const;

  // generateRay for the lanes of a packet at once (render/unit_renderer.cpp): lane k gets the ray
  // through cell (i[k], j) at offset (u0[k], u1[k]) and lens sample (lens0[k], lens1[k]), bit for
  // bit, in a vectorised loop.
  void generateRays(const int (&i)[kPacketWidth], int j, const float (&u0)[kPacketWidth],
                    const float (&u1)[kPacketWidth], const float (&lens0)[kPacketWidth],
                    const float (&lens1)[kPacketWidth], CameraRayLanes& rays) const;

  // generatePinholeRay for the lanes of a packet at once (render/unit_renderer.cpp): lane k gets
  // the ray through cell (i[k], j) at offset (u0[k], u1[k]), bit for bit, in a vectorised loop.
  void generatePinholeRays(const int (&i)[kPacketWidth], int j, const float (&u0)[kPacketWidth],
                           const float (&u1)[kPacketWidth], CameraRayLanes& rays) const;

  // The same, from explicit sensor and lens points in camera-plane coordinates
  // (x along right, y along up); used by tests of the optics.
  CameraRay rayThrough(Vec2 sensorPoint, Vec2 lensPoint) const;

  // Camera (camera/camera.h): the thin lens is its own paraxial lens; its rays weigh the
  // aperture's weight and are never stopped.
  const char* type() const override { return "thin_lens"; }
  const ThinLensCamera& paraxial() const override { return *this; }
  bool usesLensSample() const override { return true; }
  void sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const override;
  bool connects() const override { return true; }
  std::optional<CameraConnection> connect(const Vec3& p, Vec2 uLens) const override {
    return connectThrough(p, aperture_.sample(uLens) * float(lensRadius_));
  }
  ExitPupil exitPupil() const override;

  // The connection of p through lens point r (camera plane, x along right, y along up): the cell
  // the lens images the ray from r toward -toLens onto, inverting rayThrough (so the pinhole's is
  // r = 0).
  std::optional<CameraConnection> connectThrough(const Vec3& p, Vec2 r) const;

  const ThinLensParams& params() const { return params_; }
  int width() const { return width_; }
  int height() const { return height_; }
  double imageDistance() const { return imageDistance_; }  // S2
  double lensRadius() const { return lensRadius_; }        // R
  bool isPinhole() const { return lensRadius_ == 0.0; }
  const Aperture& aperture() const { return aperture_; }
  Vec3 right() const { return right_; }
  Vec3 up() const { return up_; }
  Vec3 forward() const { return forward_; }
  // The point at uSensor in cell (i, j), in the camera plane (x along right, y along up); see the
  // orientation note at the top.
  Vec2 sensorPoint(int i, int j, Vec2 uSensor) const;

 private:
  ThinLensParams params_;
  int width_, height_;
  double imageDistance_;
  double invImageDistance_, invFocalLength_;  // 1 / S2 and 1 / f, once, not per ray

  double lensRadius_;
  double importance_ = 0.0;  // w_ap S2^2 / A_cell: the importance W cos^3 theta of every cell
  Vec3 right_, up_, forward_;
  Aperture aperture_;  // its shape, in units of R
};

// Inline, so the lane loops of generateRays and generatePinholeRays evaluate the same formulas.
inline Vec2 ThinLensCamera::sensorPoint(int i, int j, Vec2 uSensor) const {
  // In the camera plane; see the orientation note at the top.
  const double x = params_.sensorWidth * ((i + double(uSensor.x)) / width_ - 0.5);
  const double y = params_.sensorHeight * (0.5 - (j + double(uSensor.y)) / height_);
  return Vec2(float(x), float(y));
}

inline CameraRay ThinLensCamera::generateRay(int i, int j, Vec2 uSensor, Vec2 uLens) const {
  return rayThrough(sensorPoint(i, j, uSensor), aperture_.sample(uLens) * float(lensRadius_));
}

inline CameraRay ThinLensCamera::generatePinholeRay(int i, int j, Vec2 uSensor) const {
  return rayThrough(sensorPoint(i, j, uSensor), Vec2(0.0f));
}

inline CameraRay ThinLensCamera::rayThrough(Vec2 s, Vec2 r) const {
  // The 2013 report's eq. 1 in the camera frame: the incident direction n1 from the sensor point
  // (s, -S2) to the lens point (r, 0), scaled to a unit axial component, is bent to
  //     n2 = n1 - r / f.
  // Every ray from s then meets the focal plane at -s * S1 / S2, whatever r is.
  const double dx = (double(r.x) - s.x) * invImageDistance_ - r.x * invFocalLength_;
  const double dy = (double(r.y) - s.y) * invImageDistance_ - r.y * invFocalLength_;
  const Vec3 dir = glm::normalize(float(dx) * right_ + float(dy) * up_ + forward_);
  return CameraRay{params_.position + r.x * right_ + r.y * up_, dir};
}

// Focal length from an angle of view across a sensor extent L, 2013 report eq. 4: alpha = 2 atan(L / 2f).
double focalLengthFromAngleOfView(double sensorExtent, double angleOfViewDegrees);

// The axis's name in the scene format: horizontal, vertical, diagonal, smaller, larger.
const char* fovAxisName(FovAxis axis);

// The sensor's extent along an axis (width, height, diagonal, the smaller or larger side).
double sensorExtent(double sensorWidth, double sensorHeight, FovAxis axis);

// The angle of view in degrees that a sensor extent L at distance S2 behind the lens sees:
// 2 atan(L / 2 S2). At infinity focus S2 = f; focused nearer, S2 > f and the angle narrows.
double angleOfViewDegrees(double sensorExtent, double imageDistance);

}  // namespace lensfarm
