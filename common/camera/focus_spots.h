#pragma once
// The blur of points on the plane of focus, across the image (docs/figure7.md): the
// report's Figure 7d question. At f/1.4 the author saw "focus only in the centre of the image"
// and guessed at optical aberration, "either because a thin lens is not of ideal shape for
// focusing light, or that the implementation of the thin lens is a completely flat surface"
// (2013 report §5.3). These functions measure the spot that a point ON the plane of focus makes on the
// sensor, at image heights from the centre to the corner, for three cameras:
//
//  - kSeedEquationAsWritten: the report's eq. 1, n2 = n1 - r/f, with n1 the *unit* incident
//    direction, as §4.1.2 defines it. Its transverse part is n1's (r - s) / |(r - s, S2)|, where
//    an ideal lens needs (r - s) / S2: the bend r/f is the right one only for n1 scaled to a unit
//    axial component. With the unit vector it is too strong by |(r - s, S2)| / S2 = 1 / cos(theta)
//    (theta the ray's angle to the axis behind the lens): the ray bundle from a sensor point no
//    longer meets in one point of the focal plane, off the axis (oblique rays) and, less, on it
//    (marginal rays).
//  - kIdealThinLens: lensfarm's thin lens (ThinLensCamera::rayThrough, the renderer's own code):
//    eq. 1 with n1 scaled to a unit axial component, which images the focal plane onto the sensor
//    without aberration at every aperture and field (Hecht, Optics, §5.2.3).
//  - a real lens (RealLensCamera): every ray traced through the prescription.
//
// Method: for a sensor point at a fraction `field` of the half-diagonal (toward the sensor's
// upper right corner), a raysAcross x raysAcross grid of lens samples (the cameras' own
// [0,1)^2 -> aperture maps) gives the camera rays; each is intersected with the plane of focus
// (perpendicular to the axis at focus_distance from the lens centre, or from a real lens's front
// vertex); their spread there, around its centroid, is brought back to the sensor by the
// magnification, S2 / S1 for the thin lens and |sensor point| / |centroid| for a real lens (its
// own, distortion included; on the axis, that of the next field point). Rays carry the camera's
// weight (a real lens's irradiance weight). Result: the RMS spot diameter (twice the RMS distance
// from the centroid), in the scene's units on the sensor, to compare with the circle of
// confusion c = d / 1500 that the report's depth of field assumes (camera/depth_of_field.h).
#include <string>
#include <vector>

#include "common/camera/real_lens_camera.h"
#include "common/camera/thin_lens_camera.h"

namespace lensfarm {

struct FocusSpot {
  double field = 0.0;        // fraction of the sensor's half-diagonal, 0 (centre) .. 1 (corner)
  double imageHeight = 0.0;  // distance of the sensor point from the centre, scene units
  double rmsDiameter = 0.0;  // on the sensor, scene units
  double passing = 1.0;      // share of the lens samples whose ray got out (a real lens vignettes)
};

enum class ThinLensRule { kSeedEquationAsWritten, kIdealThinLens };

// `steps` + 1 field points from the centre to the corner. The camera must have an aperture. The
// sensor's height must be resolved (ThinLensCamera::params() of the scene's camera): 0 is taken
// as a square sensor.
std::vector<FocusSpot> thinLensFocusSpots(const ThinLensParams& params, ThinLensRule rule, int steps,
                                          int raysAcross = 48);
std::vector<FocusSpot> realLensFocusSpots(const ThinLensParams& frame, const RealLensParams& lens, int steps,
                                          int raysAcross = 48);

// A plot of RMS spot diameter (in circles of confusion) against image height (fraction of the
// half-diagonal) on a log axis, one line per series, with the line y = 1 (acceptably sharp), as an
// SVG document.
struct SpotSeries {
  std::string label;
  std::string colour;  // an SVG colour
  std::vector<FocusSpot> spots;
};
std::string focusSpotsSvg(const std::vector<SpotSeries>& series, double circleOfConfusion, const std::string& title);

}  // namespace lensfarm
