#pragma once
// A denoiser for rendered images (docs/aovs.md "Denoising"): the edge-avoiding à-trous wavelet
// filter of Dammertz et al. 2010 ("Edge-Avoiding À-Trous Wavelet Transform for fast Global
// Illumination Filtering", HPG 2010), with the variance-guided colour weight of SVGF (Schied et
// al. 2017, "Spatiotemporal Variance-Guided Filtering", HPG 2017).
//
// Conventions: colours are linear radiance as in the EXR's beauty; the guides are the AOV layers
// of docs/aovs.md: "albedo" (R, G, B), "normal" (X, Y, Z; not necessarily unit length) and
// "variance" (R, G, B: the variance of each pixel's MEAN, i.e. of the beauty value itself).
//
// Iteration i = 0..N-1 applies the 5x5 B3-spline kernel h = (1/16, 1/4, 3/8, 1/4, 1/16) ⊗ h with
// its taps 2^i pixels apart to the previous iteration's result:
//     c'_p = Σ_q h(q) w(p,q) c_q / Σ_q h(q) w(p,q)
//     v'_p = Σ_q h(q)² w(p,q)² v_q / (Σ_q h(q) w(p,q))²    (the variance of c'_p, as SVGF filters it)
//     w(p,q) = w_colour · w_normal · w_albedo
//     w_colour = exp(-|c_p - c_q|² / (σ_c² (g_p + min(g_p, g_q)) + ε))
//     w_normal = max(0, n̂_p · n̂_q)^σ_n
//     w_albedo = exp(-|a_p - a_q|² / σ_a²)
// |.|² and v sum the three channels, so for two pixels of one true value E|c_p - c_q|² = v_p + v_q;
// g is a 3x3 binomial blur of the variance (as SVGF does: a steadier estimate, for the weight only).
// min(g_p, g_q) rather than g_q, as in Rousselle et al. 2012's variance cancellation: a pixel of
// large variance (a firefly, a light's edge) does not make its calm neighbours accept it.
// In the first iteration, whose pixels are independent, w_colour compares the 3x3 binomial blurs of
// c_p and c_q (with g scaled to their variance): neighbourhoods, as non-local means compares
// patches (Buades et al. 2005), which keeps the skewed noise of Monte Carlo pixels from biasing
// flat regions low (a dark pixel preferring dark neighbours).
//
// The filter works on demodulated colour (irradiance): c = beauty / max(albedo, 1e-3) per channel,
// v = variance / max(albedo, 1e-3)², and the result is multiplied back by the same factor, so a
// texture's detail (in the albedo) is never blurred. A pixel whose albedo is 0 in every channel
// (background, lights) is filtered as it is.
//
// Deterministic: no random numbers; each output pixel of an iteration is computed from the previous
// iteration's buffer by one task, so the bits do not depend on the thread count.
#include <string>
#include <vector>

#include "common/film/image.h"

namespace lensfarm {

struct DenoiseOptions {
  int iterations = 5;          // à-trous levels, step 2^i (5: taps up to 62 pixels either side)
  double strength = 1.0;       // multiplies σ_c: more smooths more, and blurs more low-contrast edges
  double sigmaColour = 2.0;    // σ_c at strength 1, in standard deviations of the colour difference
  double sigmaNormal = 128.0;  // σ_n, the exponent of the normal weight (SVGF's value)
  double sigmaAlbedo = 0.1;    // σ_a: an albedo difference (over R, G, B) of σ_a multiplies the weight by 1/e
  // Use the albedo and normal layers (and demodulate by albedo). Off: the colour weight alone (the
  // documented fallback for files without those layers).
  bool useGuides = true;
};

// The names of the guide layers `denoise` needs with useGuides that `image` lacks (in the order
// albedo, normal, variance), empty if it has them all. A layer counts when it has the channels
// listed above.
std::vector<std::string> missingDenoiseGuides(const Image& image);

// The guides `denoise` uses on `image` with `options`, for messages: e.g. "albedo, normal,
// variance", "variance" or "colour only (variance estimated from 3x3 neighbourhoods)".
std::string denoiseGuidesUsed(const Image& image, const DenoiseOptions& options);

// The denoised image: its beauty filtered; every input layer kept; and a layer "noisy" (R, G, B)
// holding the input beauty bit for bit (or, if the input already has one, that older raw image).
//  - With useGuides, throws std::invalid_argument if albedo or normal is missing
//    (missingDenoiseGuides says which); without, they are ignored.
//  - Without a variance layer, each pixel's variance is estimated from the colour: the sample
//    variance of the calmest 3x3 window containing it (after SVGF's spatial fallback for pixels
//    without history).
//  - A pixel whose beauty or variance is not finite is kept as it is and given no weight in its
//    neighbours' sums: a NaN or infinity never spreads.
Image denoise(const Image& noisy, const DenoiseOptions& options = {});

}  // namespace lensfarm
