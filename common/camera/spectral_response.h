#pragma once
// How an RGB radiance is a spectrum, how the sensor's three channels respond to a spectrum, and
// how a camera sample draws its wavelength (for chromatic aberration through a real lens;
// docs/optics.md "Chromatic aberration").
//
// Units and conventions (written once, here):
//  - Wavelengths in nanometres (in air). The sensor sees [400, 700) nm, cut into three equal
//    bands: blue [400, 500), green [500, 600), red [600, 700), the band model the diffraction
//    starburst uses too (film/diffraction_psf.h).
//  - The scene is RGB (math/vec.h). A radiance (r, g, b) is the step spectrum that is r over the
//    red band, g over the green band and b over the blue band:  L(lambda) = sum_c L_c 1_c(lambda).
//  - Sensor channel c responds with s_c(lambda) = 1_c(lambda) / |band c|: the normalised band
//    (integral 1, never negative). It reads  integral s_c(lambda) L(lambda) dlambda = L_c, so
//    RGB -> spectrum -> sensor RGB is the identity, exactly: through a lens that does not
//    disperse, the spectral estimator below converges to the RGB image. (A smooth basis instead,
//    e.g. Smits 1999 or Jakob and Hanika 2019's sigmoid spectra, round-trips through the CIE
//    matching functions only approximately; an exact round trip needs sensor responses that are
//    the basis's dual, which for overlapping non-negative functions take negative values.)
//
// The estimator. Tracing a camera ray at wavelength lambda (through a dispersive lens each
// wavelength leaves the lens along its own ray, ray_lambda) returns the RGB radiance L(ray_lambda)
// the scene sends back along it; its spectral value at lambda is L_band(lambda)(ray_lambda). A
// wavelength drawn with density p(lambda) estimates channel c by
//     s_c(lambda) L_band(lambda)(ray_lambda) / p(lambda).
// A sample takes a band b, then a wavelength uniform within it: p(lambda) = 1 / (3 |band b|) when b
// is chosen with probability 1/3, proportional to the response, so the estimate is
// kBandWeight * L_b(ray_lambda) = 3 L_b in channel b and 0 in the others. The bands are
// stratified over a pixel's samples: sample s of a pixel takes band (s + o) mod 3, with o a
// uniform offset per pixel, so every band is marginally equally likely (unbiased) and every
// three consecutive samples of a pixel cover the three bands once (a sample count that is a
// multiple of 3 balances them exactly).
//
// Hero wavelengths (Wilkie, Nawaz, Droske, Weidlich and Hanika, "Hero wavelength spectral
// sampling", Computer Graphics Forum 33(4), EGSR 2014). There one path carries C wavelengths: a
// randomly drawn hero and C - 1 more at equal rotations over the spectrum, stratifying it, with
// the C estimates combined by multiple importance sampling, for as long as the path's vertices
// do not depend on the wavelength; at a dispersive specular refraction only the hero's
// direction is sampled, the others' densities vanish and they are dropped. A real lens refracts
// dispersively at the very first vertices of every camera path, so no camera path can carry
// secondary wavelengths: each wavelength takes its own camera ray. What carries over is the
// rotation: the C = 3 stratified wavelengths (one per band) are spread over consecutive samples
// of a pixel instead of one path. No MIS across wavelengths is needed: beyond the lens the scene
// is RGB, constant within a band, so the path's radiance is the same for every wavelength of its
// band.
#include <cmath>
#include <cstdint>

namespace lensfarm::spectral {

inline constexpr int kBands = 3;
// Band edges from short to long wavelengths: band 0 is blue, 1 green, 2 red.
inline constexpr double kBandEdges[kBands + 1] = {400.0, 500.0, 600.0, 700.0};
// 1 / p(lambda) times the response s_c(lambda) of the band's channel (see above).
inline constexpr float kBandWeight = 3.0f;

// The RGB channel (0 r, 1 g, 2 b) of a band, and back.
inline constexpr int channelOfBand(int band) { return kBands - 1 - band; }
inline constexpr int bandOfChannel(int channel) { return kBands - 1 - channel; }

// Channel c's response s_c(lambda), 1/nm.
double response(int channel, double wavelengthNm);

struct WavelengthSample {
  double nm = 0.0;
  int channel = 0;  // the RGB channel the sample estimates
};
// The wavelength of sample `sampleIndex` of a pixel: band (sampleIndex + o) mod 3 with the
// pixel's offset o = floor(3 uPixel), uniform within it at the fraction of 3 u (see above). `u` is
// the sample's value of the wavelength dimension, `uPixel` the pixel's sample 0's, both in
// [0, 1): on sample 0 the offset takes the integer part of 3 u and the point the fraction, which
// are independent, so every sample's band and point are uniform and independent.
inline WavelengthSample sampleWavelength(uint64_t sampleIndex, float uPixel, float u) {
  const int band = int((sampleIndex + uint64_t(float(kBands) * uPixel)) % kBands);
  const float t = float(kBands) * u;
  const double lo = kBandEdges[band], hi = kBandEdges[band + 1];
  return WavelengthSample{lo + (hi - lo) * double(t - std::floor(t)), channelOfBand(band)};
}

}  // namespace lensfarm::spectral
