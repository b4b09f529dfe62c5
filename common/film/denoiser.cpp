#include "common/film/denoiser.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lensfarm {

namespace {

constexpr double kMinAlbedo = 1e-3;  // the demodulation's floor: beauty / max(albedo, kMinAlbedo)
// Keeps the colour weight defined where the variance is 0 (a converged image): then only equal
// colours mix, and the image comes back unchanged.
constexpr double kColourEpsilon = 1e-30;
constexpr double kLargestFloat = double(std::numeric_limits<float>::max());
// The B3-spline taps of Dammertz et al. 2010.
constexpr double kB3[5] = {1.0 / 16, 1.0 / 4, 3.0 / 8, 1.0 / 4, 1.0 / 16};

// Indices of `names` among `layer`'s channels, or an empty vector if one is missing.
std::vector<size_t> channelIndices(const ImageLayer& layer, const std::vector<std::string>& names) {
  std::vector<size_t> indices;
  for (const std::string& name : names) {
    const auto it = std::find(layer.channels.begin(), layer.channels.end(), name);
    if (it == layer.channels.end()) return {};
    indices.push_back(size_t(it - layer.channels.begin()));
  }
  return indices;
}

// Layer `name`'s three channels `names` as 3 floats per pixel, or an empty vector if the layer or
// a channel is missing.
std::vector<float> guide(const Image& image, const std::string& name, const std::vector<std::string>& names) {
  const ImageLayer* layer = image.layer(name);
  if (!layer) return {};
  const std::vector<size_t> c = channelIndices(*layer, names);
  const size_t pixels = size_t(image.width) * size_t(image.height);
  if (c.empty() || layer->values.size() != pixels * layer->channels.size()) return {};
  std::vector<float> out(3 * pixels);
  for (size_t p = 0; p < pixels; ++p)
    for (size_t k = 0; k < 3; ++k) out[3 * p + k] = layer->values[p * layer->channels.size() + c[k]];
  return out;
}

const std::vector<std::string> kRgb{"R", "G", "B"}, kXyz{"X", "Y", "Z"};

std::vector<float> albedoGuide(const Image& image) { return guide(image, "albedo", kRgb); }
std::vector<float> normalGuide(const Image& image) { return guide(image, "normal", kXyz); }
std::vector<float> varianceGuide(const Image& image) { return guide(image, "variance", kRgb); }

bool finite3(const float* v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// x^e for the normal weight: by squaring when e is a whole number (σ_n = 128: seven squarings).
double power(double x, double e) {
  if (e != std::floor(e) || e < 0 || e > 1e6) return std::pow(x, e);
  double result = 1.0, base = x;
  for (auto n = static_cast<uint64_t>(e); n; n >>= 1) {
    if (n & 1) result *= base;
    base *= base;
  }
  return result;
}

// What the iterations share: the image's size and guides.
struct Guides {
  int width = 0, height = 0;
  std::vector<float> normal;         // unit length, or 0 (no surface); empty without guides
  std::vector<float> albedo;         // empty without guides
  std::vector<unsigned char> valid;  // finite colour, variance and guides
};

// What each iteration filters: the demodulated colour and its variance, 3 per pixel (in double: a
// float firefly divided by a small albedo, or its variance, may exceed the float range).
struct Signal {
  std::vector<double> colour, variance;
};

template <class Body>
void forEachRow(int height, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) body(y);
  });
}

// Calls visit(q, dx, dy) for each valid pixel q = (x + dx, y + dy) of the 3x3 neighbourhood of
// (x, y) inside the image.
template <class Visit>
void forValidNeighbours3x3(const Guides& s, int x, int y, const Visit& visit) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= s.width || qy >= s.height) continue;
      const size_t q = size_t(qy) * size_t(s.width) + size_t(qx);
      if (s.valid[q]) visit(q, dx, dy);
    }
}

// What the colour weight compares: a colour and its variance (summed over the channels) per pixel.
struct ColourGuide {
  std::vector<double> colour;  // 3 per pixel
  std::vector<double> g;       // 1 per pixel
};

// The colour weight's inputs for one level. g is the channel-summed variance blurred by the 3x3
// binomial kernel over valid pixels (renormalised at the borders), as in SVGF. With `patches` (the
// first level, whose pixels are the render's own, independent), the colour is blurred by the same
// kernel and g scaled to that blurred colour's variance, Σh² / (Σh)² of it: pixels are compared by
// their 3x3 neighbourhoods, as non-local means compares patches (Buades et al. 2005), which makes
// the weight far less sensitive to the skewed noise of Monte Carlo pixels (a dark outlier is not
// preferred for being close to a dark centre). Later levels compare the filtered pixels themselves.
ColourGuide colourGuide(const Guides& s, const Signal& in, bool patches) {
  ColourGuide out{in.colour, std::vector<double>(size_t(s.width) * size_t(s.height), 0.0)};
  constexpr double kBinomial[3] = {0.25, 0.5, 0.25};
  forEachRow(s.height, [&](int y) {
    for (int x = 0; x < s.width; ++x) {
      double variance = 0.0, weight = 0.0, weight2 = 0.0, colour[3] = {0, 0, 0};
      forValidNeighbours3x3(s, x, y, [&](size_t q, int dx, int dy) {
        const double h = kBinomial[dx + 1] * kBinomial[dy + 1];
        variance += h * (in.variance[3 * q] + in.variance[3 * q + 1] + in.variance[3 * q + 2]);
        for (int k = 0; k < 3; ++k) colour[k] += h * in.colour[3 * q + k];
        weight += h;
        weight2 += h * h;
      });
      const size_t p = size_t(y) * size_t(s.width) + size_t(x);
      if (!(weight > 0)) continue;
      out.g[p] = variance / weight;
      if (!patches) continue;
      out.g[p] *= weight2 / (weight * weight);
      for (int k = 0; k < 3; ++k) out.colour[3 * p + k] = colour[k] / weight;
    }
  });
  return out;
}

// One à-trous level with taps `step` pixels apart; the new colour and variance.
Signal atrousLevel(const Guides& s, const Signal& in, int step, const DenoiseOptions& o) {
  const ColourGuide compared = colourGuide(s, in, step == 1);
  const std::vector<double>& g = compared.g;
  const double sigmaC = o.sigmaColour * o.strength;
  const double colourScale = sigmaC * sigmaC;
  const double albedoScale = 1.0 / (o.sigmaAlbedo * o.sigmaAlbedo);
  const bool guided = !s.normal.empty();
  Signal out = in;
  forEachRow(s.height, [&](int y) {
    for (int x = 0; x < s.width; ++x) {
      const size_t p = size_t(y) * size_t(s.width) + size_t(x);
      if (!s.valid[p]) continue;
      const double* cp = &compared.colour[3 * p];
      double sum[3] = {0, 0, 0}, varSum[3] = {0, 0, 0}, weightSum = 0.0;
      for (int j = -2; j <= 2; ++j) {
        const int qy = y + j * step;
        if (qy < 0 || qy >= s.height) continue;
        for (int i = -2; i <= 2; ++i) {
          const int qx = x + i * step;
          if (qx < 0 || qx >= s.width) continue;
          const size_t q = size_t(qy) * size_t(s.width) + size_t(qx);
          if (!s.valid[q]) continue;
          const double* cq = &compared.colour[3 * q];
          double d2 = 0.0;
          for (int k = 0; k < 3; ++k) d2 += (cp[k] - cq[k]) * (cp[k] - cq[k]);
          // g_p + min(g_p, g_q), not g_p + g_q: a pixel of large variance (a firefly, a light's
          // edge) must not make its calm neighbours accept it (Rousselle et al. 2012's cancellation
          // term); where the variance is uniform the two are equal.
          double w = std::exp(-d2 / (colourScale * (g[p] + std::min(g[p], g[q])) + kColourEpsilon));
          if (guided && w > 0.0) {
            const float *np = &s.normal[3 * p], *nq = &s.normal[3 * q];
            const bool surfaceP = np[0] != 0 || np[1] != 0 || np[2] != 0;
            const bool surfaceQ = nq[0] != 0 || nq[1] != 0 || nq[2] != 0;
            if (surfaceP != surfaceQ) continue;
            if (surfaceP) {
              const double cosine = double(np[0]) * nq[0] + double(np[1]) * nq[1] + double(np[2]) * nq[2];
              w *= power(std::max(0.0, cosine), o.sigmaNormal);
            }
            const float *ap = &s.albedo[3 * p], *aq = &s.albedo[3 * q];
            double a2 = 0.0;
            for (int k = 0; k < 3; ++k) a2 += (double(ap[k]) - aq[k]) * (double(ap[k]) - aq[k]);
            if (a2 > 0.0) w *= std::exp(-a2 * albedoScale);
          }
          if (!(w > 0.0)) continue;
          const double hw = kB3[i + 2] * kB3[j + 2] * w;
          for (int k = 0; k < 3; ++k) {
            sum[k] += hw * in.colour[3 * q + k];
            varSum[k] += hw * hw * in.variance[3 * q + k];
          }
          weightSum += hw;
        }
      }
      // weightSum > 0: the centre tap has w = 1 (equal colour, normal and albedo).
      for (int k = 0; k < 3; ++k) {
        out.colour[3 * p + k] = sum[k] / weightSum;
        out.variance[3 * p + k] = varSum[k] / (weightSum * weightSum);
      }
    }
  });
  return out;
}

// The variance of each pixel's value where no variance layer says it: the per-channel sample
// variance of the colour over a valid 3x3 window, from the window, among the nine that contain the
// pixel, whose variance (summed over the channels) is smallest. Near an edge some window lies on
// the pixel's side of it, so the edge's contrast is not taken for noise (a window centred on the
// pixel would make every edge look noisy, and blur it: on a Cornell box at 8 spp that raised the
// relMSE 2.7x where this lowers it 8.6x). On flat regions the smallest of nine estimates is low,
// which makes the filter stricter, not blurrier.
std::vector<double> spatialVariance(const Guides& s, const std::vector<double>& colour) {
  std::vector<double> window(colour.size(), 0.0);
  forEachRow(s.height, [&](int y) {
    for (int x = 0; x < s.width; ++x) {
      double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
      int n = 0;
      forValidNeighbours3x3(s, x, y, [&](size_t q, int, int) {
        ++n;
        for (int k = 0; k < 3; ++k) {
          sum[k] += colour[3 * q + k];
          sum2[k] += colour[3 * q + k] * colour[3 * q + k];
        }
      });
      const size_t p = size_t(y) * size_t(s.width) + size_t(x);
      for (int k = 0; k < 3 && n > 1; ++k) window[3 * p + k] = std::max(0.0, (sum2[k] - sum[k] * sum[k] / n) / (n - 1));
    }
  });
  std::vector<double> v(colour.size(), 0.0);
  forEachRow(s.height, [&](int y) {
    for (int x = 0; x < s.width; ++x) {
      const size_t p = size_t(y) * size_t(s.width) + size_t(x);
      size_t calmest = p;
      double least = std::numeric_limits<double>::infinity();
      forValidNeighbours3x3(s, x, y, [&](size_t q, int, int) {
        const double total = window[3 * q] + window[3 * q + 1] + window[3 * q + 2];
        if (total < least) {
          least = total;
          calmest = q;
        }
      });
      for (int k = 0; k < 3; ++k) v[3 * p + k] = window[3 * calmest + k];
    }
  });
  return v;
}

}  // namespace

std::vector<std::string> missingDenoiseGuides(const Image& image) {
  std::vector<std::string> missing;
  if (albedoGuide(image).empty()) missing.push_back("albedo");
  if (normalGuide(image).empty()) missing.push_back("normal");
  if (varianceGuide(image).empty()) missing.push_back("variance");
  return missing;
}

std::string denoiseGuidesUsed(const Image& image, const DenoiseOptions& options) {
  const bool variance = !varianceGuide(image).empty();
  if (options.useGuides)
    return variance ? "albedo, normal, variance" : "albedo, normal (variance estimated from 3x3 neighbourhoods)";
  return variance ? "variance" : "colour only (variance estimated from 3x3 neighbourhoods)";
}

Image denoise(const Image& noisy, const DenoiseOptions& options) {
  const size_t pixels = size_t(noisy.width) * size_t(noisy.height);
  if (noisy.rgb.size() != 3 * pixels)
    throw std::invalid_argument("denoise: the beauty's size is not width x height x 3");
  Guides s;
  Signal signal;
  s.width = noisy.width;
  s.height = noisy.height;
  std::vector<float> albedo, normal;
  if (options.useGuides) {
    albedo = albedoGuide(noisy);
    normal = normalGuide(noisy);
    if (albedo.empty() || normal.empty())
      throw std::invalid_argument("denoise: the image lacks the albedo or normal layer (see missingDenoiseGuides)");
  }
  const std::vector<float> variance = varianceGuide(noisy);

  // Demodulation (docs/aovs.md "Denoising"): factor = max(albedo, kMinAlbedo) per channel, or 1
  // where the albedo is 0 in every channel (nothing was reflected: background, lights).
  std::vector<double> factor(3 * pixels, 1.0);
  s.valid.assign(pixels, 1);
  signal.colour.resize(3 * pixels);
  signal.variance.assign(3 * pixels, 0.0);
  for (size_t p = 0; p < pixels; ++p) {
    const float* c = &noisy.rgb[3 * p];
    bool ok = finite3(c);
    if (!variance.empty()) ok = ok && finite3(&variance[3 * p]);
    if (!albedo.empty()) {
      const float* a = &albedo[3 * p];
      ok = ok && finite3(a) && finite3(&normal[3 * p]);
      if (ok && (a[0] > 0 || a[1] > 0 || a[2] > 0))
        for (int k = 0; k < 3; ++k) factor[3 * p + k] = std::max(double(a[k]), kMinAlbedo);
    }
    s.valid[p] = ok;
    for (int k = 0; k < 3; ++k) {
      const double f = factor[3 * p + k];
      signal.colour[3 * p + k] = ok ? c[k] / f : 0.0;
      if (!variance.empty() && ok) signal.variance[3 * p + k] = std::max(0.0, double(variance[3 * p + k])) / (f * f);
    }
  }
  if (variance.empty()) signal.variance = spatialVariance(s, signal.colour);
  if (!albedo.empty()) {
    s.albedo = std::move(albedo);
    s.normal = std::move(normal);
    for (size_t p = 0; p < pixels; ++p) {
      float* n = &s.normal[3 * p];
      const double length = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
      for (int k = 0; k < 3; ++k) n[k] = length > 0 ? float(n[k] / length) : 0.0f;
    }
  }

  for (int i = 0; i < options.iterations; ++i) signal = atrousLevel(s, signal, 1 << i, options);

  Image out = noisy;
  for (size_t p = 0; p < pixels; ++p)
    if (s.valid[p])
      for (int k = 0; k < 3; ++k)  // a weighted mean of finite floats, remodulated: kept in float range
        out.rgb[3 * p + k] =
            float(std::clamp(signal.colour[3 * p + k] * factor[3 * p + k], -kLargestFloat, kLargestFloat));
  // The raw image stays available: an existing "noisy" layer (a second pass) is the older raw one.
  const ImageLayer* raw = noisy.layer("noisy");
  if (!raw || channelIndices(*raw, kRgb).empty()) {
    out.layers.erase(
        std::remove_if(out.layers.begin(), out.layers.end(), [](const ImageLayer& l) { return l.name == "noisy"; }),
        out.layers.end());
    out.layers.push_back({"noisy", kRgb, noisy.rgb});
  }
  return out;
}

}  // namespace lensfarm
