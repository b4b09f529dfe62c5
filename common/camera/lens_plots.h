#pragma once
// A lens designer's plots of a real lens (`lensfarm lens --plots DIR`, docs/cli.md), as small
// self-contained SVG documents: distortion against field angle, relative illumination against
// image height, and spot diagrams across the field. The numbers come from lens_analysis.h; this
// file only draws. Conventions are lens_system.h's (mm, +z toward the image).
#include <string>
#include <vector>

#include "common/camera/lens_analysis.h"
#include "common/camera/lens_system.h"

namespace lensfarm {

// One curve of a line plot.
struct PlotSeries {
  std::string name, colour;
  std::vector<std::pair<double, double>> points;
  bool dashed = false;
};

// Axes with ticks, the series and a legend; the y range includes 0 and every point.
std::string linePlotSvg(const std::string& title, const std::string& xLabel, const std::string& yLabel,
                        const std::vector<PlotSeries>& series);

// Distortion (%) against field angle (degrees), from analyzeField.
std::string distortionSvg(const std::vector<FieldPoint>& field);

// Relative illumination and the transmitted cross-section (vignetting alone) against image
// height (mm), with the cos^4 law of the same field angles for comparison.
std::string illuminationSvg(const std::vector<IlluminationPoint>& table);

// Spot diagrams at `angles` (degrees) on the film plane at `filmZ` (NaN: the paraxial focus), one
// panel each, centred on the rays' centroid, all at one scale, with the Airy disk's first dark
// ring (radius 1.22 lambda N, N the working f-number efl / entrance pupil) for scale.
std::string spotDiagramsSvg(const LensSystem& lens, const std::vector<double>& angles, double filmZ = NAN);

}  // namespace lensfarm
