#pragma once
// What the renderer asks of a camera (in the spirit of pbrt-v4's Camera and Mitsuba 3's Sensor).
// Three cameras implement it: PinholeCamera (camera/pinhole_camera.h: no lens sample),
// ThinLensCamera (camera/thin_lens_camera.h: the 2013 report's thin lens and sensor) and
// RealLensCamera (camera/real_lens_camera.h: every surface of a lens prescription). The scene
// picks one (scene/scene_camera.h, the one registry); the pixel loop (render/unit_renderer.cpp),
// the light tracer (render/light_tracer.cpp), the AOVs (render/aov_tracer.cpp) and diffraction
// (scene/scene_diffraction.cpp) see only this interface.
//
// Conventions, the same for every camera:
//  - The sensor has width x height cells; cell (i, j) has i along the camera's `right` and j down
//    its `up`, and sees the scene inverted, as through a lens (thin_lens_camera.h, "Sensor
//    orientation"); the flip is undone once, when a sensor is developed (film/sensor.h).
//  - A camera sample is a point of a cell (uSensor in [0,1)^2), a point of the lens (uLens in
//    [0,1)^2, read only where usesLensSample()) and, for a spectral camera, a wavelength in nm.
//  - It gives a ray (origin and unit direction in render space) and a weight that multiplies the
//    radiance the ray brings back. Weight 0: the camera stopped the ray (vignetting, total internal
//    reflection in a lens): a sample of zero, counted as a path and not traced. A uniform white
//    scene reads 1 at the sensor's centre through every camera (an aperture image reads its mean
//    transmission: camera/aperture.h, "Exposure").
//  - Every camera has a paraxial thin lens (position and axes, sensor size, focal length, f-number,
//    focus distance): its own for the pinhole and the thin lens, the first-order equivalent of a
//    real lens. The effect analysis, depth AOVs and texture footprints read it.
#include <cstdint>
#include <optional>

#include "common/camera/aperture.h"
#include "common/math/lanes.h"
#include "common/math/vec.h"

namespace lensfarm {

class ThinLensCamera;

struct CameraRay {
  Vec3 origin;
  Vec3 direction;  // unit
};

// Camera rays of a packet's lanes, as arrays over the lanes.
struct CameraRayLanes {
  alignas(64) float ox[kPacketWidth], oy[kPacketWidth], oz[kPacketWidth];
  alignas(64) float dx[kPacketWidth], dy[kPacketWidth], dz[kPacketWidth];

  CameraRay ray(int lane) const {
    return CameraRay{Vec3(ox[lane], oy[lane], oz[lane]), Vec3(dx[lane], dy[lane], dz[lane])};
  }
  void set(int lane, const CameraRay& ray) {
    ox[lane] = ray.origin.x, oy[lane] = ray.origin.y, oz[lane] = ray.origin.z;
    dx[lane] = ray.direction.x, dy[lane] = ray.direction.y, dz[lane] = ray.direction.z;
  }
};

// The camera samples of a packet's lanes [0, count) in one sensor row: lane k is a point of cell
// (column[k], row) at (u0[k], u1[k]), a lens point (lens0[k], lens1[k]) and a wavelength. Lanes
// past `count` hold cell 0's centre values and get a harmless ray, so vector loops run whole.
struct CameraSampleLanes {
  int count = 0;
  int row = 0;
  int column[kPacketWidth];
  alignas(64) float u0[kPacketWidth], u1[kPacketWidth];
  alignas(64) float lens0[kPacketWidth], lens1[kPacketWidth];  // where usesLensSample()
  double wavelengthNm[kPacketWidth];                           // where spectral()
};

// A point connected to the camera through the lens (pbrt-v4's Camera::SampleWi; the importance
// of Veach's thesis, ch. 10): what the light tracer splats into the sensor.
struct CameraConnection {
  Vec3 lensPoint;   // where the connection meets the lens
  Vec3 toLens;      // unit, from the point toward lensPoint
  float distance2;  // squared distance from the point to lensPoint
  float distance;   // its square root
  uint64_t cell;    // the sensor cell the lens images the connection onto: j * width + i
  // The importance W_e of that cell in the connection's direction per unit solid angle at the lens,
  // over cos(theta) of the ray's angle to the optical axis: a vertex at distance d whose surface
  // cosine toward the lens is cos_c adds  W * cos_c / d^2  times its own throughput (the
  // light tracer's (LT)). For the thin lens W = w_ap S2^2 / (A_cell cos^3 theta).
  double importance;
};

// The exit pupil as diffraction sees it (film/diffraction_psf.h): its shape, in units of its
// radius, and the working f-number (the film's distance behind the pupil over its diameter).
struct ExitPupil {
  Aperture shape;
  double workingFNumber = 0.0;
};

class Camera {
 public:
  virtual ~Camera() = default;

  // The camera's name in the scene format ("pinhole", "thin_lens", "real_lens").
  virtual const char* type() const = 0;
  // The paraxial thin lens (see the top).
  virtual const ThinLensCamera& paraxial() const = 0;
  int width() const;
  int height() const;

  // Whether rays read the lens sample, are traced at a wavelength each, or can be stopped (weight 0).
  virtual bool usesLensSample() const = 0;
  virtual bool spectral() const { return false; }
  virtual bool stopsRays() const { return false; }

  // The rays of a packet's lanes and their weights (see the top); lanes past s.count get a
  // harmless ray. The same bits as one ray at a time, in a vector loop where the camera has one.
  virtual void sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const = 0;

  // Whether light paths can be connected to the camera (connect below); a real lens cannot: its
  // importance has no closed form (light tracing is off with one: scene/effects.h).
  virtual bool connects() const { return false; }
  // The connection of point p to the lens point for uLens, or nothing where the lens images it off
  // the sensor (or p is on the lens).
  virtual std::optional<CameraConnection> connect(const Vec3& p, Vec2 uLens) const {
    (void)p, (void)uLens;
    return std::nullopt;
  }

  virtual ExitPupil exitPupil() const = 0;
};

}  // namespace lensfarm
