#include "common/medium/homogeneous_medium.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm {

HomogeneousMedium::HomogeneousMedium(const Spectrum& sigmaA, const Spectrum& sigmaS, float g)
    : sigmaA_(sigmaA), sigmaS_(sigmaS), sigmaT_(sigmaA + sigmaS), phase_(g) {}

HomogeneousMedium HomogeneousMedium::fromAttenuation(const Spectrum& attenuationColor, float attenuationDistance,
                                                     const Spectrum& scatteringAlbedo, float g) {
  Spectrum sigmaT(0.0f);
  for (int c = 0; c < 3; ++c) {
    // -ln(1) = 0 and x / infinity = 0: c = 1 or d = infinity attenuate nothing.
    sigmaT[c] = attenuationColor[c] >= 1.0f ? 0.0f : -std::log(attenuationColor[c]) / attenuationDistance;
  }
  const Spectrum sigmaS = scatteringAlbedo * sigmaT;
  return HomogeneousMedium(sigmaT - sigmaS, sigmaS, g);
}

namespace {
// exp(-sigma t) in double with 0 * infinity = 0.
double transmit(double sigma, double t) { return sigma > 0.0 ? std::exp(-sigma * t) : 1.0; }
}  // namespace

float HomogeneousMedium::freeFlightDensity(float t) const {
  double p = 0.0;
  for (int c = 0; c < 3; ++c) p += sigmaT_[c] > 0.0f ? double(sigmaT_[c]) * transmit(sigmaT_[c], t) : 0.0;
  return float(p / 3.0);
}

FreeFlight HomogeneousMedium::sampleFreeFlight(float tMax, float uChannel, float u) const {
  Spectrum ratio(1.0f);
  return sampleFreeFlight(tMax, std::min(2, int(uChannel * 3.0f)), u, ratio);
}

FreeFlight HomogeneousMedium::sampleFreeFlight(float tMax, int hero, float u, Spectrum& ratio) const {
  const double sigma = sigmaT_[hero];
  // Inverse CDF of p_hero: t = -ln(1 - u) / sigma (log1p keeps small u exact); sigma = 0 never stops.
  const double t = sigma > 0.0 ? -std::log1p(-double(u)) / sigma : std::numeric_limits<double>::infinity();
  const bool pass = t >= double(tMax);
  // Double throughout: a channel's exp(-sigma t) may underflow float where the mixture does not.
  // f: the integrand's factor per channel; p: each channel's density of this outcome.
  double f[3], p[3], mean = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double tr = transmit(sigmaT_[c], pass ? double(tMax) : t);
    p[c] = pass ? tr : double(sigmaT_[c]) * tr;
    f[c] = pass ? tr : double(sigmaS_[c]) * tr;
    mean += double(ratio[c]) * p[c] / 3.0;
  }
  // mean >= ratio[hero] p[hero] / 3 > 0: the hero's outcome has positive density (a pass: its
  // exp(-sigma tMax) >= 1 - u), and ratio[hero] stays positive along the path, in exact arithmetic.
  // Should float underflow make them all 0 after a very long walk, the path ends (weight 0)
  // rather than carry a NaN.
  FreeFlight out;
  if (!(mean > 0.0)) return out;
  out.scattered = !pass;
  out.t = pass ? tMax : float(t);
  for (int c = 0; c < 3; ++c) {
    out.weight[c] = float(f[c] / mean);
    ratio[c] = float(double(ratio[c]) * p[c] / mean);
  }
  return out;
}

float sssSingleScatteringAlbedo(float a) { return 1.0f - std::exp(a * (-5.09406f + a * (2.61188f - a * 4.31805f))); }

SssCoefficients sssCoefficients(const Spectrum& albedo, const Spectrum& distance) {
  SssCoefficients out;
  for (int c = 0; c < 3; ++c) {
    const float a = albedo[c];
    const float s = 1.9f - a + 3.5f * (a - 0.8f) * (a - 0.8f);
    const float sigmaT = 1.0f / (distance[c] * s);
    const float alpha = sssSingleScatteringAlbedo(a);
    out.sigmaS[c] = alpha * sigmaT;
    out.sigmaA[c] = (1.0f - alpha) * sigmaT;
  }
  return out;
}

namespace {

std::string show(const Spectrum& s) {
  std::ostringstream o;
  o << "[" << s.r << ", " << s.g << ", " << s.b << "]";
  return o.str();
}

// Each channel must satisfy ok(); otherwise one InputError naming the field.
template <typename Ok>
void requireChannels(const Spectrum& s, Ok ok, const std::string& where, const std::string& field,
                     const std::string& rule) {
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(s[c]) || !ok(s[c])) throw InputError(where, field + ": " + rule + ", got " + show(s));
}

}  // namespace

void validateHomogeneousMedium(const Spectrum& sigmaA, const Spectrum& sigmaS, float g, const std::string& where,
                               const std::string& field) {
  // At most kMaxCoefficient: a free flight is then at least 1e-30 scene units long and sigma_t
  // stays finite in float (sigma_a + sigma_s of two values near 3.4e38 would be infinite, and
  // exp(-inf * 0) NaN).
  const auto inRange = [](float v) { return v >= 0.0f && v <= kMaxCoefficient; };
  requireChannels(sigmaA, inRange, where, field + ".sigma_a", "must be in [0, 1e30] (1 / scene units)");
  requireChannels(sigmaS, inRange, where, field + ".sigma_s", "must be in [0, 1e30] (1 / scene units)");
  validateHenyeyGreensteinG(g, where, field + ".g");
}

void validateAttenuation(const Spectrum& attenuationColor, float attenuationDistance, const Spectrum& scatteringAlbedo,
                         float g, const std::string& where, const std::string& field) {
  requireChannels(
      attenuationColor, [](float v) { return v > 0.0f && v <= 1.0f; }, where, field + ".attenuation_color",
      "must lie in (0, 1] (1: no attenuation)");
  for (int c = 0; c < 3; ++c)
    if (attenuationColor[c] < 1.0f && -std::log(attenuationColor[c]) / attenuationDistance > kMaxCoefficient)
      throw InputError(where, field +
                                  ".attenuation_distance: makes sigma_t above 1e30 / scene unit (a free flight "
                                  "shorter than 1e-30); use a longer distance");
  if (std::isnan(attenuationDistance) || !(attenuationDistance > 0.0f))
    throw InputError(where, field + ".attenuation_distance: must be > 0 (infinity: no attenuation), got " +
                                std::to_string(attenuationDistance));
  requireChannels(
      scatteringAlbedo, [](float v) { return v >= 0.0f && v <= 1.0f; }, where, field + ".scattering_albedo",
      "must lie in [0, 1]");
  validateHenyeyGreensteinG(g, where, field + ".g");
}

void validateSss(const Spectrum& albedo, const Spectrum& distance, const std::string& where, const std::string& field) {
  requireChannels(
      albedo, [](float v) { return v >= 0.0f && v <= 1.0f; }, where, field + ".albedo", "must lie in [0, 1]");
  requireChannels(
      distance, [](float v) { return v > 0.0f; }, where, field + ".mean_free_path",
      "must be finite and > 0 (scene units)");
}

}  // namespace lensfarm
