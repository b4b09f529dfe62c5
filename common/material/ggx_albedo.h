#pragma once
// The directional albedo of a GGX conductor with a perfect Fresnel term (F = 1) and its cosine-
// weighted average, tabulated once, and the Kulla-Conty multiple-scattering lobe built from them.
//
// Kulla & Conty 2017, "Revisiting Physically Based Shading at Imageworks" (SIGGRAPH course
// "Physically Based Shading in Theory and Practice"), §"Energy compensation": a single-scattering
// microfacet BRDF with F = 1 reflects only
//   E(mu_o) = integral over the hemisphere of f_ss(wo, wi) cos(theta_i) dw_i  <  1
// of the light; the rest was scattered more than once between microfacets, which the model leaves
// out. Their compensation lobe
//   f_ms(wo, wi) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)),
//   E_avg = 2 integral_0^1 E(mu) mu dmu,
// is reciprocal and restores exactly the missing energy: its albedo is 1 - E(mu_o), since
// 2 integral (1 - E(mu)) mu dmu = 1 - E_avg. With a coloured Fresnel term F, the single-scattering
// lobe keeps its F and the compensation lobe is multiplied by (their eq. for F_ms)
//   F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)),   F_avg = 2 integral_0^1 F(mu) mu dmu,
// the sum of the geometric series of further bounces, each reflecting F_avg and escaping with
// probability E_avg (kullaContyFresnel below; it is 1 when F = 1). For Schlick's F with F0,
// F_avg = (1 + 20 F0) / 21.
//
// Measured numbers (height-correlated Smith, F = 1; GgxAlbedoTable's nodes, checked by the tests):
//  - alpha = 1: E(mu) = 1 - mu ln(1 + 1/mu) in closed form (D = 1/pi is constant there), so
//    E(1) = 1 - ln 2 = 0.3069 and E_avg = (4/3)(1 - ln 2) = 0.4091: the roughest GGX conductor
//    loses 59 % of the light to the missing multiple scattering, not the 40 % sometimes quoted:
//    E_avg = 0.6 is reached at alpha = 0.65 (E_avg(0.5) = 0.700).
//  - E(mu) -> 1 at grazing incidence for every alpha (the visible facets are the highest ones,
//    whose reflection escapes), with a dip at mu ~ alpha for narrow lobes (E = 0.89 at mu = alpha
//    = 0.01); hence the table's nodes are dense near mu = 0 (see GgxAlbedoTable).
#include <algorithm>
#include <array>
#include <cmath>

#include "common/material/microfacet.h"
#include "common/math/sampling.h"
#include "common/math/vec.h"

namespace lensfarm {

// E(mu, alpha) on a 32 x 32 grid, computed on first use by instance() (4.3 M evaluations of the
// visible normal sampler, about 0.1-0.2 s on one core), thread-safely, then read-only.
//
// Grid: nodes uniform in sqrt(mu) and in sqrt(alpha) (= perceptual roughness):
//   mu_i = (i / 31)^2,  alpha_j = (j / 31)^2,
// which puts 5 nodes below mu = 0.02 where E changes fastest, and resolves narrow lobes (the
// first non-zero alpha node is 1.04e-3, about kSmoothAlpha). Lookups are bilinear in
// (sqrt(mu), sqrt(alpha)). Accuracy (tests): nodes within 1e-4 of the exact integral; lookups
// between nodes within 2e-3 for alpha >= 0.05, 1e-2 for alpha in [0.01, 0.05] and 3.5e-2 for
// alpha < 0.01, the last two only at grazing angles mu < 0.02, where the dip of E at mu ~ alpha
// falls between nodes (and where 1 - E(mu) weighs almost nothing in E_avg).
//
// E_avg is the exact integral 2 integral E(mu) mu dmu of the interpolated E (piecewise linear in
// sqrt(mu)), so the compensation lobe's albedo is 1 - E(mu_o) for the same interpolated E: single
// plus multiple scattering sums to 1 up to the interpolation error of E at mu_o alone.
class GgxAlbedoTable {
 public:
  static constexpr int kMuCount = 32;
  static constexpr int kAlphaCount = 32;

  static const GgxAlbedoTable& instance() {
    static const GgxAlbedoTable table;  // C++11 "magic static": initialised once, thread-safely
    return table;
  }

  static float muNode(int i) { return square(float(i) / float(kMuCount - 1)); }
  static float alphaNode(int j) { return square(float(j) / float(kAlphaCount - 1)); }

  // E(mu, alpha): the directional albedo of the single-scattering GGX BRDF with F = 1 and
  // height-correlated masking-shadowing, for the view at cos(theta_o) = mu. mu and alpha are
  // clamped to [0, 1]. In [0, 1]; 1 at alpha = 0 (the mirror) and at mu = 0.
  float E(float mu, float alpha) const {
    const Cell c = cell(mu, alpha);
    auto at = [&](int i, int j) { return e_[size_t(j * kMuCount + i)]; };
    return (1.0f - c.fa) * ((1.0f - c.fm) * at(c.i, c.j) + c.fm * at(c.i + 1, c.j)) +
           c.fa * ((1.0f - c.fm) * at(c.i, c.j + 1) + c.fm * at(c.i + 1, c.j + 1));
  }

  // E_avg(alpha) = 2 integral_0^1 E(mu, alpha) mu dmu (the cosine-weighted hemispherical average).
  float Eavg(float alpha) const {
    const Cell c = cell(0.0f, alpha);
    return (1.0f - c.fa) * eAvg_[size_t(c.j)] + c.fa * eAvg_[size_t(c.j + 1)];
  }

  // Kulla-Conty's compensation lobe for F = 1 (see the file comment):
  //   f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)),
  // a BRDF value (multiply by cos(theta_i) to integrate). Symmetric in (mu_o, mu_i); 0 when
  // either direction is at or below the horizon, and for lobes so narrow (1 - E_avg < 1e-6) that
  // nothing is missing. Colour it with kullaContyFresnel(F_avg, Eavg(alpha)).
  float multipleScatteringF1(float muO, float muI, float alpha) const {
    if (!(muO > 0.0f) || !(muI > 0.0f)) return 0.0f;
    const float missing = 1.0f - Eavg(alpha);
    if (!(missing > 1e-6f)) return 0.0f;
    return (1.0f - E(muO, alpha)) * (1.0f - E(muI, alpha)) / (kPi * missing);
  }

  // The directional albedo by quadrature, as the table's nodes are computed. With m sampled from
  // the visible normals seen from wo and wi its mirror reflection, f cos / pdf = F G2 / G1(wo)
  // (the visible-normal estimator of Heitz & d'Eon 2014, "Importance Sampling Microfacet-Based
  // BSDFs using the Distribution of Visible Normals"; here F = 1), so E(mu) is the mean of G2 / G1(wo) = (1 + Lambda_o)
  // / (1 + Lambda_o + Lambda_i) = zi (zo + So) / (zi So + zo Si) over u in [0,1)^2 (0 where wi is below the horizon).
  // This ratio is in [0, 1], so E <= 1, and it is 1 at zo = 0. The points: a Fibonacci lattice (v_k, u2_k) = ((k + 1/2)
  // / N, frac((k F' + 1/2) / N)) with N = F_n and F' = F_(n-1) (F' = round(N / golden ratio) for any N), and u1 = 1 -
  // (1 - v)^3 with weights 3 (1 - v)^2 normalised to sum to 1. The substitution packs points near u1 = 1, the lobe's
  // tail, where the reflection crosses the horizon (a kink in the integrand, at 1 - u1 ~ alpha^2 at normal incidence);
  // the lattice gives every point its own u1, so that kink is resolved N times finer than by an n x n grid of as many
  // points (whose error at normal incidence, where the kink is a line of constant u1, was 10x larger). Error below 1e-4
  // at the 4181 points used for the nodes (tests), accumulated in double.
  static constexpr int kQuadraturePoints = 4181;  // F_19
  static double albedo(float mu, float alpha, int points = kQuadraturePoints) {
    alpha = clamp01(alpha);
    if (alpha <= 0.0f) return 1.0;  // the mirror, with F = 1
    const GgxDistribution ggx{std::max(alpha, GgxDistribution::kMinAlpha)};
    mu = clamp01(mu);
    const Vec3 wo(std::sqrt(std::max(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    const float so = ggx.stretchedLength(wo);
    const long n = std::max(points, 1);
    const long step = std::lround(double(n) * 0.6180339887498949);  // N / golden ratio
    double sum = 0.0, weightSum = 0.0;
    for (long k = 0; k < n; ++k) {
      const double v = (double(k) + 0.5) / double(n), oneMinusV = 1.0 - v;
      const float u1 = float(1.0 - oneMinusV * oneMinusV * oneMinusV);
      const float u2 = float((double((k * step) % n) + 0.5) / double(n));
      const double weight = 3.0 * oneMinusV * oneMinusV;
      weightSum += weight;
      const Vec3 m = ggx.sampleVisibleNormalPolar(wo, Vec2(u1, u2));
      const Vec3 wi = 2.0f * glm::dot(wo, m) * m - wo;
      if (!(wi.z > 0.0f)) continue;
      const float si = ggx.stretchedLength(wi);
      sum += weight * double(wi.z * (mu + so) / (wi.z * so + mu * si));
    }
    return sum / weightSum;
  }

 private:
  GgxAlbedoTable() {
    for (int j = 0; j < kAlphaCount; ++j) {
      for (int i = 0; i < kMuCount; ++i) e_[size_t(j * kMuCount + i)] = float(albedo(muNode(i), alphaNode(j)));
      // E_avg = 2 integral_0^1 E(mu) mu dmu = 4 integral_0^1 E(t) t^3 dt with mu = t^2, E linear in
      // t on each [t0, t1] of width h: E = e0 + (e1 - e0)(t - t0) / h. Exactly, per segment:
      //   integral E t^3 dt = e0 (t1^4 - t0^4) / 4 + (e1 - e0) / h ((t1^5 - t0^5) / 5 - t0 (t1^4 - t0^4) / 4).
      double integral = 0.0;
      const double h = 1.0 / (kMuCount - 1);
      for (int i = 0; i + 1 < kMuCount; ++i) {
        const double t0 = i * h, t1 = (i + 1) * h;
        const double e0 = e_[size_t(j * kMuCount + i)], e1 = e_[size_t(j * kMuCount + i + 1)];
        const double p4 = (std::pow(t1, 4) - std::pow(t0, 4)) / 4.0, p5 = (std::pow(t1, 5) - std::pow(t0, 5)) / 5.0;
        integral += e0 * p4 + (e1 - e0) / h * (p5 - t0 * p4);
      }
      eAvg_[size_t(j)] = float(4.0 * integral);
    }
  }

  static float square(float x) { return x * x; }
  static float clamp01(float x) { return x > 0.0f ? std::min(x, 1.0f) : 0.0f; }  // NaN -> 0

  struct Cell {
    int i, j;      // lower node indices
    float fm, fa;  // fractions towards the upper nodes
  };
  // The grid cell of (mu, alpha) in the (sqrt(mu), sqrt(alpha)) coordinates of the nodes.
  static Cell cell(float mu, float alpha) {
    const float x = std::sqrt(clamp01(mu)) * float(kMuCount - 1);
    const float y = std::sqrt(clamp01(alpha)) * float(kAlphaCount - 1);
    const int i = std::clamp(int(x), 0, kMuCount - 2), j = std::clamp(int(y), 0, kAlphaCount - 2);
    return Cell{i, j, std::clamp(x - float(i), 0.0f, 1.0f), std::clamp(y - float(j), 0.0f, 1.0f)};
  }

  std::array<float, kMuCount * kAlphaCount> e_{};
  std::array<float, kAlphaCount> eAvg_{};
};

// Kulla-Conty's Fresnel factor for the compensation lobe (see the file comment): the energy the
// further bounces return, F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), per channel. Exactly 1 for
// F_avg = 1; 0 for F_avg = 0. f_ms,F(wo, wi) = multipleScatteringF1(...) * kullaContyFresnel(...).
inline Spectrum kullaContyFresnel(const Spectrum& fAvg, float eAvg) {
  return fAvg * fAvg * eAvg / (Spectrum(1.0f) - fAvg * (1.0f - eAvg));
}

}  // namespace lensfarm
