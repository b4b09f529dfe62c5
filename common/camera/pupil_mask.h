#pragma once
// The aperture as a transmission mask on a square grid, for the Fraunhofer diffraction pattern
// (film/diffraction_psf.h).
//
// The pupil is the thin lens's aperture shape (camera/thin_lens_camera.h, sampleAperture): the unit
// disk (blades = 0), or the regular n-gon inscribed in it with a vertex at angle `rotation`
// (radians, counter-clockwise from `right`). Cell (c, r) of the n x n grid covers
//     x in [-1 + 2c / n, -1 + 2(c + 1) / n] along `right`,  y in [-1 + 2r / n, -1 + 2(r + 1) / n] along `up`
// (row 0 at the bottom), so the unit disk just fits the grid; its value is the fraction of the
// cell inside the pupil (4 x 4 point samples), which keeps a small grid's edges from stair-casing.
//
// TODO(issue 23): the Aperture class (camera/aperture.h, with curved blades and aperture images)
// has its own rasterize(n); diffractionKernelFor (film/diffraction_psf.cpp) should call it instead.
#include <vector>

namespace lensfarm {

std::vector<double> rasterizePupil(int n, int blades, double rotation);

}  // namespace lensfarm
