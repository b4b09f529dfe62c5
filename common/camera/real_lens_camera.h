#pragma once
// A camera with a real lens (docs/optics.md "Real lenses"): the sensor behind a
// LensSystem (lens_system.h), every camera ray traced through every surface of the lens.
//
// Frame. The lens's front vertex sits at the camera's `position`; the lens's +z (toward the film)
// is the camera's -forward, its x is `right`, its y is `up` (camera/thin_lens_camera.h). The
// prescription is in millimetres; `sceneUnitsPerMm` maps it into the scene (0.001 for a scene in
// metres). The film is the plane behind the last vertex on which the lens focuses
// `focusDistance` (scene units, measured from the front vertex): the paraxial (thick-lens) film
// distance refined to the exact one, where an axial point there has the least RMS spot
// (LensSystem::exactFocus; moving the film is moving the lens group, the object distance being
// measured from the front vertex). Sensor cells are laid out as the thin lens's are, so the
// inverted image is undone the same way when a sensor is developed.
//
// A camera ray starts at a point of a sensor cell, aims at a point of the rear element sampled
// uniformly within the exit pupil's bounds for that point's distance from the axis (bounds
// precomputed for kPupilBins radii by tracing a grid, as pbrt-v4's RealisticCamera does, so few
// samples are wasted), and is traced out through the lens. A ray the lens stops (vignetting,
// total internal reflection) is a sample of zero. A ray that gets out carries the weight
//     w = A cos^4(theta) / d^2
// (A the bounds' area, theta the ray's angle to the axis at the film, d the film-to-rear-vertex
// distance: the irradiance measure of Kolb, Mitchell and Hanrahan, "A realistic camera model for
// computer graphics", SIGGRAPH 1995), divided by its mean at the film's centre: a uniform white
// scene reads 1 at the centre, as with the 2013 report's cameras, and falls off toward the corners as
// the lens's relative illumination (vignetting and cos^4) says.
//
// Colour. A lens whose glasses disperse (Abbe numbers, lens_system.h) is traced at each camera
// sample's own wavelength (camera/spectral_response.h: the sensor's bands, the estimator, and
// why each wavelength takes its own camera ray); its pupil bounds then cover the rays of every
// band. A lens that does not disperse is traced at the d line: RGB, no wavelength work.
#include <array>
#include <memory>
#include <optional>
#include <string>

#include "common/camera/lens_system.h"
#include "common/camera/thin_lens_camera.h"

namespace lensfarm {

struct RealLensParams {
  std::shared_ptr<const LensSystem> lens;  // already stopped down to the scene's f_number
  std::string name;                        // the lens file, for messages
  double sceneUnitsPerMm = 0.001;
};

class RealLensCamera final : public Camera {
 public:
  static constexpr int kPupilBins = 64;

  // `frame`: position, look_at, up, sensor size and focus distance (its focal length and f-number
  // are the lens's thin-lens equivalent, for the effect analysis). InputError naming
  // focus_distance when the lens cannot focus there.
  RealLensCamera(const ThinLensParams& frame, const RealLensParams& lens, int width, int height);

  // The ray for a point of sensor cell (i, j) at offset uSensor in [0,1)^2, aimed with uLens in
  // [0,1)^2 within the exit pupil's bounds, through the lens at `wavelengthNm`; nullopt if the
  // lens stops it. `weight`: see above (the same for every wavelength).
  std::optional<CameraRay> generateRay(int i, int j, Vec2 uSensor, Vec2 uLens, float* weight,
                                       double wavelengthNm = LensSystem::kWavelengthD) const;
  // Camera (camera/camera.h): the frame's thin lens is the lens's paraxial equivalent; a ray the
  // lens stops weighs 0; camera samples are spectral where the lens disperses.
  const char* type() const override { return "real_lens"; }
  const ThinLensCamera& paraxial() const override { return frame_; }
  bool usesLensSample() const override { return true; }
  bool spectral() const override { return params_.lens->disperses(); }
  bool stopsRays() const override { return true; }
  void sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const override;
  // The stop is round; the working f-number is the film's distance behind the exit pupil over its
  // diameter (paraxial).
  ExitPupil exitPupil() const override;

  double filmZ() const { return filmZ_; }  // mm behind the front vertex
  const LensSystem& lens() const { return *params_.lens; }
  // The share of camera rays over the whole sensor that get through the lens (a filmGrid^2 grid
  // of film points, pupilGrid^2 pupil samples each), traced when asked (reports and tests; not at
  // load): how many samples the pupil bounds waste on rays the lens stops.
  double passingFraction(int filmGrid = 32, int pupilGrid = 8) const;

 private:
  struct Bounds {
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0;  // on the rear vertex's plane, the film point on +x
    bool empty() const { return !(x1 > x0 && y1 > y0); }
  };
  // Film point (mm, in the lens frame) and rear-plane point -> the ray through the lens (lens
  // frame) and its unnormalised weight, or nullopt.
  std::optional<LensRay> traceOut(const DVec3& film, const DVec3& rear,
                                  double wavelengthNm = LensSystem::kWavelengthD) const;
  Bounds boundsAt(double radius) const;
  double weightOf(const DVec3& film, const DVec3& rear, double area) const;

  ThinLensCamera frame_;
  RealLensParams params_;
  double filmZ_ = 0.0, rearZ_ = 0.0, maxFilmRadius_ = 0.0;
  double rearRadius_ = 0.0;  // half the square searched for pupil bounds on the rear vertex's plane
  std::array<Bounds, kPupilBins> bounds_{};
  double normalisation_ = 1.0;  // 1 / the mean weight at the film's centre
};

}  // namespace lensfarm
