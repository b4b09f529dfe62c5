#pragma once
// Diffraction by the aperture (docs/optics.md "Diffraction"): the point-spread function
// (PSF) that turns a point of light into an Airy disk, or into a starburst behind a bladed
// aperture, applied to the developed image (film/psf_convolution.h).
//
// Units: lengths on the sensor in millimetres, wavelengths in nanometres. The scene's own length
// unit is tied to millimetres by DiffractionSettings::sceneUnitsPerMm (thin lens) or the real
// lens's scene_units_per_mm.
//
// Physics. In the Fraunhofer approximation the field on the sensor is the Fourier transform of
// the pupil function P (1 inside the exit pupil, 0 outside), evaluated at spatial frequency
// x / (lambda z), z the distance from the exit pupil to the sensor (Goodman, "Introduction to
// Fourier Optics", 3rd ed., eq. 4-13 and 5-44):
//     PSF_lambda(x) ~ |FT{P}(x / (lambda z))|^2,  normalised to unit integral.
// Sampled on an N x N grid with the pupil's diameter D covering M = N / Q samples (spacing
// dp = D / M, Q the zero-padding factor), the discrete transform gives the PSF at spacing
//     dx = lambda z / (N dp) = lambda N_w / Q,        N_w = z / D the working f-number.
// In units of lambda N_w the sampled pattern is therefore the same for every wavelength: it is
// computed once per pupil shape (FraunhoferPattern) and read per wavelength at spacing
// lambda N_w / Q (exact for a pupil that does not depend on lambda). A round pupil gives the Airy
// pattern, whose first dark ring is at 1.22 lambda N_w and holds 83.8 % of the energy (Born &
// Wolf, "Principles of Optics", 8.5.2).
//
// Padding. |FT{P}|^2 is the transform of P's autocorrelation, which is 2D wide: sampling the
// intensity without aliasing needs a grid at least twice the pupil (Q >= 2, Nyquist). lensfarm
// takes Q = 4 (sampling at lambda N_w / 4, so the first ring falls 4.9 samples out and the pixel
// resampling below interpolates a smooth function) and N = 1024, so the pattern spans
// +-128 lambda N_w: what lies beyond (about 0.2 % of an Airy pattern's energy, more along a
// bladed aperture's spikes) folds back into the grid (the DFT's periodicity) and stays in the sum.
//
// Colour (the band model). Each RGB channel is the mean of the PSFs of `wavelengthsPerChannel`
// wavelengths at the centres of equal parts of a box band: blue 400-500 nm, green 500-600 nm,
// red 600-700 nm, equal weights. A real sensor's colour filters overlap and peak; the boxes keep
// what makes a starburst colourful: the rings of each channel, at radii proportional to lambda,
// blur into each other and fringe red outside.
//
// On the sensor. Each wavelength's PSF is integrated over the sensor's cells, giving a kernel in
// image pixels: where the pattern's samples are at most two cells apart, exactly as its bilinear
// interpolant (each sample spread by a tent of half-width one sample, so all its energy lands in
// the cells); where they are farther apart, the interpolant at 2 x 2 points a cell. The kernel
// keeps the square of half-width 2h cells, h that of the smallest square holding kKeptEnergy of
// the pattern at 700 nm (never beyond the image's own size), with a round raised-cosine taper
// from h out to its edge (a hard edge shows as a square around very bright lights); the energy
// it keeps is reported, then it is renormalised to unit sum, so the image's total energy is
// conserved (light spread past the frame's edges leaves it, as it leaves a real sensor).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "common/camera/aperture.h"

namespace lensfarm {

// What the PSF depends on besides the pupil's shape.
struct DiffractionOptics {
  int blades = 0;                                  // 0: round; for messages (the shape: camera/aperture.h)
  double rotation = 0.0;                           // radians, counter-clockwise from `right`
  double workingFNumber = 0.0;                     // N_w = z / D
  double pixelWidthMm = 0.0, pixelHeightMm = 0.0;  // one sensor cell
  int width = 0, height = 0;                       // the image, in pixels
};

// The radius of the Airy pattern's first dark ring, 1.22 lambda N_w, in mm.
inline double airyRadiusMm(double wavelengthNm, double workingFNumber) {
  return 1.22 * wavelengthNm * 1e-6 * workingFNumber;
}

// The sampled Fraunhofer pattern of a pupil, in units of lambda N_w.
struct FraunhoferPattern {
  int size = 0;                   // N
  double spacing = 0.0;           // 1 / Q: sample spacing in units of lambda N_w
  std::vector<double> intensity;  // N x N, row-major, rows along `up`, centre at (N/2, N/2); unit sum
  // Bilinear at (x, y) along (right, up), in units of lambda N_w; 0 outside the grid.
  double at(double x, double y) const;
};

// The pattern of an aperture (camera/aperture.h: round, straight or curved blades, an image),
// rasterised over its bounding square on a (gridSize / padding)^2 grid, zero-padded to
// gridSize x gridSize (a power of two; padding >= 2).
FraunhoferPattern fraunhoferPattern(const Aperture& aperture, int gridSize = 1024, int padding = 4);
// The same for straight blades (0: round) with a vertex at `rotation` radians from `right`.
FraunhoferPattern fraunhoferPattern(int blades, double rotation, int gridSize = 1024, int padding = 4);

// The wavelengths, in nm, channel c (0 red, 1 green, 2 blue) averages (the band model above).
std::vector<double> channelWavelengths(int channel, int perChannel);

inline constexpr double kKeptEnergy = 0.995;

// A PSF per channel on the image's pixel grid.
struct DiffractionKernel {
  int radius = 0;                              // each channel is (2 radius + 1)^2 pixels, centred
  std::array<std::vector<double>, 3> channel;  // row-major, row 0 at the top (image orientation); unit sum
  double keptEnergy = 1.0;  // the smallest share of a channel's PSF kept (crop and taper), before renormalising
  double at(int c, int dx, int dy) const { return channel[c][size_t(dy + radius) * (2 * radius + 1) + (dx + radius)]; }
};

DiffractionKernel diffractionKernel(const FraunhoferPattern& pattern, const DiffractionOptics& optics,
                                    int wavelengthsPerChannel);

}  // namespace lensfarm
