// The GGX microfacet distribution (common/material/microfacet.h) and the Kulla-Conty albedo table
// (common/material/ggx_albedo.h): the distribution's normalisation, its masking functions against
// their definitions, the visible normals (normalised, and sampled as their pdf says, by the
// chi-squared harness of tests/support/chi2.h), the directional albedo against brute-force Monte
// Carlo and the closed form at alpha = 1, energy conservation of the compensated lobe, and finite
// values at grazing angles and extreme widths.
#include "common/material/microfacet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include "common/material/ggx_albedo.h"
#include "tests/support/chi2.h"

namespace lensfarm {
namespace {

constexpr double kPiD = M_PI;

Vec3 direction(double thetaDegrees, double phi = 0.7) {
  const double t = thetaDegrees * kPiD / 180.0;
  return Vec3(float(std::sin(t) * std::cos(phi)), float(std::sin(t) * std::sin(phi)), float(std::cos(t)));
}

// Independent double-precision references, in the papers' own (tangent) forms.
// [W07 eq. 33]: D(m) = 1 / (pi alpha^2 cos^4 (1 + tan^2 / alpha^2)^2).
double dReference(double cosT, double alpha) {
  if (cosT <= 0.0) return 0.0;
  const double tan2 = (1.0 - cosT * cosT) / (cosT * cosT);
  return 1.0 / (kPiD * alpha * alpha * std::pow(cosT, 4) * std::pow(1.0 + tan2 / (alpha * alpha), 2));
}
// [H14 eq. 72]: Lambda = (-1 + sqrt(1 + 1 / a^2)) / 2 with a = 1 / (alpha tan theta).
double lambdaReference(double cosT, double alpha) {
  const double tanT = std::sqrt(1.0 - cosT * cosT) / std::abs(cosT);
  if (tanT == 0.0) return 0.0;
  const double a = 1.0 / (alpha * tanT);
  return (-1.0 + std::sqrt(1.0 + 1.0 / (a * a))) / 2.0;
}
// [H14 eq. 99], height-correlated.
double g2Reference(double cosO, double cosI, double alpha) {
  return 1.0 / (1.0 + lambdaReference(cosO, alpha) + lambdaReference(cosI, alpha));
}

// Integrates g(m) over the hemisphere of normals by the midpoint rule in (psi, phi), where
// tan(theta_m) = alpha tan(psi): the stretch that maps GGX to its alpha = 1 shape, so that a lobe of
// any width gets the same number of points. dtheta / dpsi = alpha / (cos^2 psi + alpha^2 sin^2 psi).
double integrateOverNormals(double alpha, const std::function<double(const Vec3&)>& g, int nPsi, int nPhi) {
  double sum = 0.0;
  for (int i = 0; i < nPsi; ++i) {
    const double psi = (i + 0.5) / nPsi * kPiD / 2.0;
    const double s = std::sin(psi), c = std::cos(psi);
    const double theta = std::atan2(alpha * s, c);
    const double jacobian = std::sin(theta) * alpha / (c * c + alpha * alpha * s * s);
    for (int j = 0; j < nPhi; ++j) {
      const double phi = (j + 0.5) / nPhi * 2.0 * kPiD;
      const Vec3 m(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                   float(std::cos(theta)));
      sum += g(m) * jacobian;
    }
  }
  return sum * (kPiD / 2.0 / nPsi) * (2.0 * kPiD / nPhi);
}

TEST(MicrofacetGgx, RoughnessMapsToAlphaSquaredWithinTheSafeRange) {
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(0.5f), 0.25f);
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(1.0f), 1.0f);
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(3.0f), 1.0f);
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(0.0f), GgxDistribution::kMinAlpha);
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(-1.0f), GgxDistribution::kMinAlpha);
  EXPECT_EQ(GgxDistribution::alphaFromRoughness(std::nanf("")), GgxDistribution::kMinAlpha);
  EXPECT_TRUE(GgxDistribution{GgxDistribution::alphaFromRoughness(0.03f)}.isEffectivelySmooth());
  EXPECT_FALSE(GgxDistribution{GgxDistribution::alphaFromRoughness(0.04f)}.isEffectivelySmooth());
  EXPECT_LT(GgxDistribution::kMinAlpha, GgxDistribution::kSmoothAlpha);
}

TEST(MicrofacetGgx, DistributionMatchesWalterEq33AndIsNormalised) {
  for (float alpha : {GgxDistribution::kMinAlpha, 1e-3f, 0.01f, 0.1f, 0.5f, 1.0f}) {
    const GgxDistribution ggx{alpha};
    // The shape, against the tangent form in double, from the pole to 3 lobe widths and beyond.
    for (double t : {0.0, 0.1, 0.5, 1.0, 3.0, 30.0}) {
      const double theta = std::atan(t * alpha);
      const Vec3 m(float(std::sin(theta)), 0.0f, float(std::cos(theta)));
      EXPECT_NEAR(ggx.D(m) / dReference(std::cos(theta), alpha), 1.0, 2e-5) << "alpha " << alpha << " tan/alpha " << t;
    }
    // integral D(m) cos(theta_m) dw_m = 1 [W07 §3.1].
    const double integral = integrateOverNormals(
        alpha, [&](const Vec3& m) { return double(ggx.D(m)) * m.z; }, 512, 8);
    EXPECT_NEAR(integral, 1.0, 1e-4) << "alpha " << alpha;
    EXPECT_EQ(ggx.D(Vec3(1, 0, 0)), 0.0f);
    EXPECT_EQ(ggx.D(Vec3(0, 0, -1)), 0.0f);
  }
}

TEST(MicrofacetGgx, MaskingFunctionsMatchTheirDefinitions) {
  for (float alpha : {GgxDistribution::kMinAlpha, 0.01f, 0.3f, 1.0f}) {
    const GgxDistribution ggx{alpha};
    for (double deg : {0.0, 10.0, 45.0, 80.0, 89.0, 89.9, 100.0, 170.0}) {
      const Vec3 w = direction(deg);
      const double lambda = lambdaReference(double(w.z), alpha);
      EXPECT_NEAR(ggx.lambda(w), lambda, 1e-5 * (1.0 + lambda)) << alpha << " " << deg;
      EXPECT_NEAR(ggx.G1(w), 1.0 / (1.0 + lambda), 1e-6) << alpha << " " << deg;
      for (double deg2 : {0.0, 30.0, 70.0, 89.9}) {
        const Vec3 wi = direction(deg2, 2.5);
        const double g = ggx.G(w, wi);
        EXPECT_NEAR(g, g2Reference(double(w.z), double(wi.z), alpha), 1e-6) << alpha << " " << deg << " " << deg2;
        // Height correlation lies between independence and full correlation.
        EXPECT_GE(g, double(ggx.G1(w)) * double(ggx.G1(wi)) - 1e-6);
        EXPECT_LE(g, std::min(ggx.G1(w), ggx.G1(wi)) + 1e-6);
      }
    }
    // Closed forms: G1 = 1 at the normal, 0 at the horizon; at alpha = 1, Lambda = (1/mu - 1) / 2.
    EXPECT_EQ(ggx.G1(Vec3(0, 0, 1)), 1.0f);
    EXPECT_EQ(ggx.lambda(Vec3(0, 0, 1)), 0.0f);
    EXPECT_EQ(ggx.G1(Vec3(1, 0, 0)), 0.0f);
    EXPECT_EQ(ggx.G(Vec3(1, 0, 0), Vec3(0, 0, 1)), 0.0f);
  }
  const GgxDistribution rough{1.0f};
  for (double mu : {0.01, 0.3, 0.9}) {
    const Vec3 w(float(std::sqrt(1 - mu * mu)), 0.0f, float(mu));
    EXPECT_NEAR(rough.lambda(w), (1.0 / mu - 1.0) / 2.0, 1e-5 / mu);
  }
}

// The weak white furnace [H14]: the visible microfacets project onto w as the macro-surface
// does, integral G1(w) max(0, w.m) D(m) dm = cos(theta_w), i.e. the visible normals are normalised.
// G1 from its definition 1 / (1 + Lambda), not from the ratio form G1() uses.
TEST(MicrofacetGgx, WeakWhiteFurnace) {
  for (float alpha : {1e-3f, 0.01f, 0.1f, 0.5f, 1.0f})
    for (double deg : {0.0, 30.0, 60.0, 85.0, 89.0, 89.9}) {
      const GgxDistribution ggx{alpha};
      const Vec3 w = direction(deg);
      const double g1 = 1.0 / (1.0 + double(ggx.lambda(w)));
      const double projected = integrateOverNormals(
          alpha, [&](const Vec3& m) { return g1 * std::max(0.0, double(glm::dot(w, m))) * double(ggx.D(m)); }, 256,
          256);
      EXPECT_NEAR(projected / double(w.z), 1.0, 1e-3) << "alpha " << alpha << " theta " << deg;
    }
}

// The visible normal density D_w(m) is a pdf over m for every w, seen from above or below.
TEST(MicrofacetVndf, PdfIntegratesToOne) {
  for (float alpha : {GgxDistribution::kMinAlpha, 0.01f, 0.1f, 0.5f, 1.0f})
    for (double deg : {0.0, 30.0, 60.0, 85.0, 89.5, 89.9, 90.0, 95.0, 150.0, 180.0}) {
      const GgxDistribution ggx{alpha};
      const Vec3 w = direction(deg);
      const double integral = integrateOverNormals(
          alpha, [&](const Vec3& m) { return double(ggx.pdfVisibleNormal(w, m)); }, 256, 256);
      EXPECT_NEAR(integral, 1.0, 1e-3) << "alpha " << alpha << " theta " << deg;
      // Seen from below it is the density seen from -w.
      const Vec3 m = direction(10.0, 1.0);
      EXPECT_EQ(ggx.pdfVisibleNormal(w, m), ggx.pdfVisibleNormal(-w, m));
    }
}

struct VndfCase {
  float alpha;
  double thetaDegrees;
};

// Heitz 2018's sampler against the density, by the chi-squared test at 1 % significance with the
// Sidak correction over all cases. The cases run on two threads (the budget is the suite's).
TEST(MicrofacetVndf, SamplerMatchesItsPdfChi2) {
  std::vector<VndfCase> cases;
  for (float alpha : {0.01f, 0.1f, 0.3f, 0.7f, 1.0f})
    for (double deg : {0.0, 30.0, 60.0, 85.0, 89.5}) cases.push_back({alpha, deg});
  cases.push_back({0.3f, 120.0});  // from below the surface
  cases.push_back({0.7f, 178.0});
  std::vector<test::Chi2Result> results(cases.size());
  auto run = [&](size_t first) {
    for (size_t k = first; k < cases.size(); k += 2) {
      const GgxDistribution ggx{cases[k].alpha};
      const Vec3 w = direction(cases[k].thetaDegrees);
      test::Chi2Options o;
      o.thetaBins = 40;
      o.sampleCount = 300000;
      o.seed = 100 + k;
      results[k] = test::chi2Test([&](Vec2 u, float) { return std::optional<Vec3>(ggx.sampleVisibleNormal(w, u)); },
                                  [&](const Vec3& m) { return ggx.pdfVisibleNormal(w, m); }, o);
    }
  };
  std::thread second(run, size_t(1));
  run(0);
  second.join();
  for (size_t k = 0; k < cases.size(); ++k) {
    const test::Chi2Result& r = results[k];
    EXPECT_TRUE(test::passes(r.pValue, 0.01, int(cases.size())))
        << "alpha " << cases[k].alpha << " theta " << cases[k].thetaDegrees << "\n"
        << r.histogramDump;
    EXPECT_NEAR(r.pdfIntegral, 1.0, 1e-4) << "alpha " << cases[k].alpha << " theta " << cases[k].thetaDegrees;
    EXPECT_EQ(r.acceptedFraction, 1.0);
  }
}

// The harness has the power to see a sampler whose width is 5 % off.
TEST(MicrofacetVndf, Chi2RejectsASamplerWithTheWrongAlpha) {
  const GgxDistribution ggx{0.3f}, wrong{0.315f};
  const Vec3 w = direction(60.0);
  test::Chi2Options o;
  o.sampleCount = 300000;
  const test::Chi2Result r =
      test::chi2Test([&](Vec2 u, float) { return std::optional<Vec3>(wrong.sampleVisibleNormal(w, u)); },
                     [&](const Vec3& m) { return ggx.pdfVisibleNormal(w, m); }, o);
  EXPECT_LT(r.pValue, 1e-6) << r.histogramDump;
}

// Finite values everywhere in the documented domain: grazing (z = 0, 1e-8, 1e-30), normal
// incidence, both hemispheres, the narrowest and widest alpha, the corners of the unit square.
TEST(MicrofacetGgx, NoNanOrInfAtGrazingAndExtremeInputs) {
  std::vector<Vec3> dirs;
  for (float z : {0.0f, 1e-30f, 1e-8f, 1e-4f, 0.5f, 1.0f - 1e-7f, 1.0f})
    for (float phi : {0.0f, 0.3f, 1.5707964f, 3.1415927f})
      for (float sign : {1.0f, -1.0f}) {
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        dirs.push_back(Vec3(r * std::cos(phi), r * std::sin(phi), sign * z));
      }
  const float below1 = 1.0f - 0x1p-24f;
  const std::vector<Vec2> us = {{0, 0},          {0, 0.5f},       {0.5f, 0},        {0.5f, 0.25f},  {below1, 0},
                                {below1, 0.25f}, {below1, 0.75f}, {below1, below1}, {1e-7f, 0.75f}, {0.999f, 0.75f}};
  for (float alpha : {GgxDistribution::kMinAlpha, 1e-3f, 0.01f, 0.5f, 1.0f}) {
    const GgxDistribution ggx{alpha};
    for (const Vec3& w : dirs) {
      const std::string where = "alpha " + std::to_string(alpha) + " w (" + std::to_string(w.x) + ", " +
                                std::to_string(w.y) + ", " + std::to_string(w.z) + ")";
      EXPECT_TRUE(std::isfinite(ggx.D(w)) && ggx.D(w) >= 0.0f) << where;
      const float lambda = ggx.lambda(w);
      if (w.z == 0.0f) {
        EXPECT_EQ(lambda, std::numeric_limits<float>::infinity()) << where;
      } else {
        EXPECT_TRUE(std::isfinite(lambda) && lambda >= 0.0f) << where;
      }
      EXPECT_TRUE(ggx.G1(w) >= 0.0f && ggx.G1(w) <= 1.0f) << where;
      for (const Vec3& v : dirs) EXPECT_TRUE(ggx.G(w, v) >= 0.0f && ggx.G(w, v) <= 1.0f) << where;
      for (const Vec2& u : us) {
        const Vec3 m = ggx.sampleVisibleNormal(w, u);
        ASSERT_TRUE(std::isfinite(m.x) && std::isfinite(m.y) && std::isfinite(m.z))
            << where << " u " << u.x << " " << u.y;
        EXPECT_NEAR(glm::length(m), 1.0f, 1e-6f) << where;
        EXPECT_GE(m.z, 0.0f) << where;
        const float pdf = ggx.pdfVisibleNormal(w, m);
        EXPECT_TRUE(std::isfinite(pdf) && pdf >= 0.0f) << where;
        // Inside the square the sample is a visible normal: its density is positive.
        if (u.x > 0.0f && u.x < below1 && u.y > 0.0f && std::abs(w.z) > 0.0f) {
          EXPECT_GT(pdf, 0.0f) << where << " u " << u.x;
        }
        // On the square's rim (u.x or u.y exactly 0), which the concentric map sends to the disk's
        // rim, the sample is taken just inside: a visible normal still, not a lost sample.
        if ((u.x == 0.0f || u.y == 0.0f) && std::abs(w.z) >= 0.5f) {
          EXPECT_GT(pdf, 0.0f) << where << " u " << u.x << " " << u.y;
        }
      }
      for (const Vec3& m : dirs) EXPECT_TRUE(std::isfinite(ggx.D(w, m)) && ggx.D(w, m) >= 0.0f) << where;
    }
  }
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  for (float mu : {std::nanf(""), -1.0f, 0.0f, 1e-8f, 0.5f, 1.0f, 2.0f})
    for (float alpha : {std::nanf(""), -1.0f, 0.0f, 1e-4f, 0.5f, 1.0f, 2.0f}) {
      EXPECT_TRUE(std::isfinite(table.E(mu, alpha)) && table.E(mu, alpha) >= 0.0f && table.E(mu, alpha) <= 1.0f);
      EXPECT_TRUE(std::isfinite(table.Eavg(alpha)));
      EXPECT_TRUE(std::isfinite(table.multipleScatteringF1(mu, 0.5f, alpha)));
      EXPECT_TRUE(std::isfinite(float(GgxAlbedoTable::albedo(mu, alpha, 8))));
    }
}

// A brute-force estimate of E(mu, alpha) = integral f cos dwi with F = 1, by uniform hemisphere
// sampling of wi and the double references above (no visible-normal sampling, no table).
struct Estimate {
  double mean, standardError;
};
Estimate albedoMonteCarlo(double mu, double alpha, int n, uint64_t seed, bool cosineWeightedMu = false) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double sum = 0.0, sum2 = 0.0;
  for (int k = 0; k < n; ++k) {
    const double muO = cosineWeightedMu ? std::sqrt(uniform(rng)) : mu;  // pdf 2 mu for E_avg
    const DVec3 wo(std::sqrt(1.0 - muO * muO), 0.0, muO);
    const double z = uniform(rng), phi = 2.0 * kPiD * uniform(rng), r = std::sqrt(1.0 - z * z);
    const DVec3 wi(r * std::cos(phi), r * std::sin(phi), z);
    const DVec3 h = glm::normalize(wo + wi);
    // f cos / pdf = D(h) G2 / (4 mu_o mu_i) * mu_i * 2 pi.
    const double x = dReference(h.z, alpha) * g2Reference(muO, z, alpha) / (4.0 * muO) * 2.0 * kPiD;
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n;
  return {mean, std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n)};
}

TEST(MicrofacetAlbedo, ANarrowLobeReflectsEverything) {
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  EXPECT_EQ(table.E(1.0f, 0.0f), 1.0f);
  EXPECT_EQ(table.Eavg(0.0f), 1.0f);
  EXPECT_GT(table.E(1.0f, GgxDistribution::kSmoothAlpha), 0.9999f);
  EXPECT_GT(table.E(0.5f, GgxDistribution::kMinAlpha), 0.9999f);
  EXPECT_GT(GgxAlbedoTable::albedo(1.0f, GgxDistribution::kMinAlpha), 1.0 - 1e-6);
  EXPECT_EQ(table.multipleScatteringF1(0.5f, 0.5f, 0.0f), 0.0f);
  // Energy is lost as the surface roughens.
  for (int j = 1; j < GgxAlbedoTable::kAlphaCount; ++j)
    EXPECT_LT(table.Eavg(GgxAlbedoTable::alphaNode(j)), table.Eavg(GgxAlbedoTable::alphaNode(j - 1)));
}

// At alpha = 1, D = 1 / pi and Lambda = (1/mu - 1) / 2, so E(mu) = integral_0^1 mu_i / (mu + mu_i)
// dmu_i = 1 - mu ln(1 + 1/mu), and E_avg = (4/3)(1 - ln 2) = 0.40914: a 59 % loss.
TEST(MicrofacetAlbedo, MatchesTheClosedFormAtAlphaOne) {
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  for (int i = 0; i < GgxAlbedoTable::kMuCount; ++i) {  // the nodes: the quadrature's accuracy
    const double mu = GgxAlbedoTable::muNode(i);
    const double exact = mu > 0.0 ? 1.0 - mu * std::log(1.0 + 1.0 / mu) : 1.0;
    EXPECT_NEAR(table.E(float(mu), 1.0f), exact, 1e-4) << "mu " << mu;
  }
  for (int k = 0; k < 200; ++k) {  // between the nodes: the interpolation's
    const double mu = (k + 0.5) / 200.0;
    EXPECT_NEAR(table.E(float(mu), 1.0f), 1.0 - mu * std::log(1.0 + 1.0 / mu), 1.5e-3) << "mu " << mu;
  }
  const double eAvgExact = 4.0 / 3.0 * (1.0 - std::log(2.0));
  EXPECT_NEAR(table.Eavg(1.0f), eAvgExact, 3e-4);
  // An independent Monte Carlo estimate: mu_o with density 2 mu, wi uniform on the hemisphere.
  const Estimate mc = albedoMonteCarlo(0.0, 1.0, 400000, 7, true);
  EXPECT_NEAR(table.Eavg(1.0f), mc.mean, 4.0 * mc.standardError + 3e-4) << "standard error " << mc.standardError;
  EXPECT_NEAR(eAvgExact, 0.40914, 1e-5);
  std::printf("E_avg(alpha = 1): table %.5f, closed form %.5f, Monte Carlo %.5f +- %.5f\n", table.Eavg(1.0f), eAvgExact,
              mc.mean, mc.standardError);
}

TEST(MicrofacetAlbedo, MatchesBruteForceMonteCarlo) {
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  const double points[][2] = {{0.9, 0.3}, {0.5, 0.5}, {0.2, 0.6}, {0.7, 0.8}, {0.05, 0.45}};
  uint64_t seed = 11;
  for (const auto& p : points) {
    const Estimate mc = albedoMonteCarlo(p[0], p[1], 300000, seed++);
    // 4 standard errors plus the table's interpolation error between nodes.
    EXPECT_NEAR(table.E(float(p[0]), float(p[1])), mc.mean, 4.0 * mc.standardError + 1.5e-3)
        << "mu " << p[0] << " alpha " << p[1] << " standard error " << mc.standardError;
    EXPECT_LT(mc.standardError, 3e-3);
  }
}

// The nodes' quadrature (a 4181-point lattice) against one 7x finer (28657 points), over the grid.
TEST(MicrofacetAlbedo, NodeQuadratureIsConverged) {
  for (int j : {1, 3, 8, 16, 24, 31})
    for (int i : {0, 1, 3, 10, 20, 31}) {
      const float mu = GgxAlbedoTable::muNode(i), alpha = GgxAlbedoTable::alphaNode(j);
      EXPECT_NEAR(GgxAlbedoTable::albedo(mu, alpha), GgxAlbedoTable::albedo(mu, alpha, 28657), 1e-4)
          << "mu " << mu << " alpha " << alpha;
    }
}

// Bilinear lookups between the nodes, against the quadrature at the point itself: within the
// documented error (2e-3 for alpha >= 0.05; 1e-2 for alpha in [0.01, 0.05]).
TEST(MicrofacetAlbedo, LookupsBetweenNodesAreWithinTheDocumentedError) {
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  for (float alpha : {0.02f, 0.06f, 0.13f, 0.27f, 0.41f, 0.77f, 0.93f})
    for (int k = 0; k < 16; ++k) {
      const float mu = std::pow((float(k) + 0.37f) / 16.0f, 2.0f);  // between nodes, dense at grazing
      EXPECT_NEAR(table.E(mu, alpha), GgxAlbedoTable::albedo(mu, alpha), alpha >= 0.05f ? 2e-3 : 1e-2)
          << "mu " << mu << " alpha " << alpha;
    }
}

// Single scattering plus the Kulla-Conty lobe reflects all the light (F = 1): for alpha = 1 with
// the closed-form E as the single-scattering albedo, and for alpha = 0.5 with a fine quadrature.
TEST(MicrofacetAlbedo, CompensatedLobeConservesEnergy) {
  const GgxAlbedoTable& table = GgxAlbedoTable::instance();
  for (float alpha : {1.0f, 0.5f, 0.2f})
    for (float muO : {0.05f, 0.2f, 0.5f, 0.8f, 1.0f}) {
      const double single =
          alpha == 1.0f ? 1.0 - muO * std::log(1.0 + 1.0 / muO) : GgxAlbedoTable::albedo(muO, alpha, 256);
      // integral f_ms cos dwi = 2 pi integral_0^1 f_ms(mu_o, mu_i) mu_i dmu_i.
      double multiple = 0.0;
      const int n = 4000;
      for (int k = 0; k < n; ++k) {
        const float muI = float((k + 0.5) / n);
        multiple += double(table.multipleScatteringF1(muO, muI, alpha)) * muI;
      }
      multiple *= 2.0 * kPiD / n;
      EXPECT_GE(single + multiple, 0.99) << "alpha " << alpha << " mu " << muO;
      EXPECT_LE(single + multiple, 1.01) << "alpha " << alpha << " mu " << muO;
      EXPECT_NEAR(single + multiple, 1.0, 2e-3) << "alpha " << alpha << " mu " << muO;
      if (alpha == 1.0f) {
        EXPECT_GT(multiple, 0.05) << "the roughest lobe needs compensating";
      }
      EXPECT_EQ(table.multipleScatteringF1(muO, 0.3f, alpha), table.multipleScatteringF1(0.3f, muO, alpha));
    }
  // Coloured: the factor is 1 for white and 0 for black, and below F_avg for grey.
  EXPECT_NEAR(kullaContyFresnel(Spectrum(1.0f), 0.4f).r, 1.0f, 1e-6f);
  EXPECT_EQ(kullaContyFresnel(Spectrum(0.0f), 0.4f), Spectrum(0.0f));
  EXPECT_NEAR(kullaContyFresnel(Spectrum(0.5f), 0.4f).g, 0.25 * 0.4 / (1.0 - 0.5 * 0.6), 1e-6);
}

TEST(MicrofacetAlbedo, TableIsBuiltOnceForAllThreads) {
  std::vector<const GgxAlbedoTable*> seen(4);
  std::vector<std::thread> threads;
  for (size_t k = 0; k < seen.size(); ++k) threads.emplace_back([&, k] { seen[k] = &GgxAlbedoTable::instance(); });
  for (auto& t : threads) t.join();
  EXPECT_EQ(std::set<const GgxAlbedoTable*>(seen.begin(), seen.end()).size(), 1u);
}

}  // namespace
}  // namespace lensfarm
