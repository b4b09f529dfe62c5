#pragma once
// What a lens designer checks of a real lens (`lensfarm lens`, docs/optics.md): across the field,
// for an object at infinity, the real image height against the paraxial one (distortion), the
// fraction of a parallel beam filling the entrance pupil that gets through (vignetting), and
// the RMS spot radius at the paraxial focus; and a cross-section drawing with traced rays.
// Conventions are lens_system.h's (mm, +z toward the image).
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/lens_system.h"

namespace lensfarm {

struct FieldPoint {
  double angleDegrees = 0.0;    // of the incoming beam to the axis
  double imageHeight = 0.0;     // where the beam's centroid meets the paraxial focal plane, mm
  double paraxialHeight = 0.0;  // efl * tan(angle), mm
  double distortion = 0.0;      // imageHeight / paraxialHeight - 1 (0 on the axis)
  double transmitted = 0.0;     // the beam's rays that get through, relative to the axis's
  double rmsSpot = 0.0;         // RMS distance of its rays from their centroid, mm
};

// `steps` + 1 field angles from 0 to `maxAngleDegrees`, each a square grid of `raysAcross`^2
// parallel rays normal to the beam over the box of the rays that get through (found by a coarse
// grid over the front element's projection, so that a fisheye's beam, far from the paraxial
// entrance pupil at wide angles, is found). `transmitted` is the vignetting factor V of
// relativeIllumination below: the beam's passing cross-section over the axial one's times
// cos(angle).
std::vector<FieldPoint> analyzeField(const LensSystem& lens, double maxAngleDegrees, int steps, int raysAcross = 48,
                                     double wavelengthNm = LensSystem::kWavelengthD);

// ---------------------------------------------------------------------------------------------
// Relative illumination, from the object side (independent of the camera's image-side Kolb
// weights). A distant scene of uniform radiance L; the beam from directions within dw of the
// field angle theta carries the flux  dPhi = L A(theta) dw,  A(theta) the cross-section
// (perpendicular to the beam) of its rays that get through the lens, and lands on the film
// annulus between h(theta) and h(theta + dtheta), h the beam's centroid height on the film. With
// dw = sin(theta) dtheta dphi and dA = h dh dphi (rotational symmetry), the film's irradiance is
//     E(theta) = L A(theta) sin(theta) / (h(theta) h'(theta)),
// and on the axis (h ~ h'(0) theta) E(0) = L A(0) / h'(0)^2. Their ratio is the relative
// illumination. Writing A(theta) = V(theta) A(0) cos(theta), V the vignetting factor (the share
// of the axial beam's area, measured in a plane normal to the axis, that still passes),
//     RI(theta) = V(theta) cos(theta) sin(theta) h'(0)^2 / (h(theta) h'(theta)),
// which for a distortion-free lens (h = f tan theta, h' = f / cos^2 theta) without vignetting
// (V = 1) is the cos^4 law. A(theta) is counted on a square grid perpendicular to the beam over a box
// around the rays that pass (found on a coarse grid over the front surface's projection);
// h'(theta) is a central difference of centroids at theta +- 0.25 degrees.
struct IlluminationPoint {
  double angleDegrees = 0.0;
  double imageHeight = 0.0;  // h: the beam's centroid on the film plane, mm
  double area = 0.0;         // V: the vignetting factor (1 where nothing clips the beam)
  double relative = 0.0;     // RI: irradiance / the axis's
};
// `steps` + 1 field angles from 0 to `maxAngleDegrees`; the film plane at `filmZ` mm from the
// front vertex (NaN: the paraxial focus for an object at infinity).
std::vector<IlluminationPoint> relativeIllumination(const LensSystem& lens, double maxAngleDegrees, int steps,
                                                    double filmZ = NAN, int raysAcross = 384,
                                                    double wavelengthNm = LensSystem::kWavelengthD);
// RI at image height `h` (mm), linear between the tabulated points; NaN beyond the last.
double relativeIlluminationAt(const std::vector<IlluminationPoint>& table, double h);

// The spot diagram's rays: where a parallel beam at `angleDegrees`, `raysAcross` across the box
// of its rays that pass (as analyzeField), meets the film plane at `filmZ` (NaN: the paraxial
// focus). Rays the lens stops are left out.
std::vector<DVec3> spotHits(const LensSystem& lens, double angleDegrees, double filmZ = NAN, int raysAcross = 31,
                            double wavelengthNm = LensSystem::kWavelengthD);

// ---------------------------------------------------------------------------------------------
// Fisheye (and rectilinear) projections: the image height r of a distant point at angle theta
// for focal length f (Kingslake, A History of the Photographic Lens; Miyamoto, JOSA 54, 1964).
enum class Projection { kRectilinear, kEquidistant, kEquisolid, kOrthographic, kStereographic };
// "rectilinear" (f tan), "equidistant" (f theta), "equisolid" (2 f sin(theta/2)), "orthographic"
// (f sin), "stereographic" (2 f tan(theta/2)); nullopt for another name.
std::optional<Projection> projectionNamed(const std::string& name);
const char* projectionName(Projection p);
double projectedHeight(Projection p, double focalLength, double theta);

// The lens in section (the y-z plane) with rays of an axial beam and of one at `fieldDegrees`
// traced to the paraxial focal plane, as a self-contained SVG document.
std::string crossSectionSvg(const LensSystem& lens, double fieldDegrees);

// ---- Lateral colour (chromatic aberration; docs/optics.md "Chromatic aberration") ----
// Where an object point's image falls on the film in each sensor channel. The object point is at
// `objectDistance` mm in front of the front vertex (infinity: a parallel beam), seen at
// `fieldDegrees` from the entrance pupil's centre, in the y-z plane; the film is the plane
// z = `filmZ` (mm from the front vertex). Rays from it fill a disk 1.5 x the entrance pupil
// (raysAcross^2 of them, each weighted by the solid angle it stands for), traced at
// `wavelengthsPerBand` wavelengths evenly spread in each of the sensor's bands
// (camera/spectral_response.h); a channel's image height is the centroid of the rays that get
// through, weighted by the channel's response: what the render's channel image of a small white
// source has as its centroid. Lateral colour is red minus blue.
struct LateralColour {
  double heightRed = 0.0, heightGreen = 0.0, heightBlue = 0.0;  // mm, on the film (y)
  double lateral = 0.0;                                         // heightRed - heightBlue, mm
};
LateralColour lateralColour(const LensSystem& lens, double fieldDegrees, double objectDistance, double filmZ,
                            int raysAcross = 48, int wavelengthsPerBand = 8);

}  // namespace lensfarm
