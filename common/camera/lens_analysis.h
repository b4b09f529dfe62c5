#pragma once
// What a lens designer checks of a real lens (`lensfarm lens`, docs/optics.md): across the field,
// for an object at infinity, the real image height against the paraxial one (distortion), the
// fraction of a parallel beam filling the entrance pupil that gets through (vignetting), and
// the RMS spot radius at the paraxial focus; and a cross-section drawing with traced rays.
// Conventions are lens_system.h's (mm, +z toward the image).
#include <string>
#include <vector>

#include "camera/lens_system.h"

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
// parallel rays over a disk 1.5 x the entrance pupil (vignetting needs rays beyond it).
std::vector<FieldPoint> analyzeField(const LensSystem& lens, double maxAngleDegrees, int steps, int raysAcross = 48,
                                     double wavelengthNm = LensSystem::kWavelengthD);

// The lens in section (the y-z plane) with rays of an axial beam and of one at `fieldDegrees`
// traced to the paraxial focal plane, as a self-contained SVG document.
std::string crossSectionSvg(const LensSystem& lens, double fieldDegrees);

// ---- Lateral colour (issue 23: chromatic aberration; docs/optics.md "Chromatic aberration") ----
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
