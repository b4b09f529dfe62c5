// The Henyey-Greenstein phase function: normalisation, sampling density (chi-square), mean
// cosine, the g -> 0 limit, and validation of g.
#include <gtest/gtest.h>

#include <cmath>

#include "common/medium/phase_function.h"
#include "common/util/error.h"
#include "tests/support/chi2.h"
#include "tests/support/uniform_rng.h"

namespace lensfarm {
namespace {

constexpr float kGs[] = {-0.9f, 0.0f, 0.5f, 0.99f};

// HG's density from the textbook formula in double, independent of the code under test.
double hgReference(double g, double cosTheta) {
  return (1 - g * g) / (4 * M_PI * std::pow(1 + g * g - 2 * g * cosTheta, 1.5));
}

// A unit wi at propagation angle theta from wo = +z given x = 1 - cos(theta): wi = -(sin, 0, cos).
Vec3 wiAt(double x) {
  const double sinTheta = std::sqrt(std::max(0.0, x * (2 - x)));
  return -Vec3(float(sinTheta), 0.0f, float(1 - x));
}

TEST(HenyeyGreenstein, IntegratesToOneOverTheSphere) {
  // int p dw = 2 pi int_0^2 p(x) dx with x = 1 - cos(theta); the peak of g = 0.99 (width ~1e-4 in
  // x) is resolved by Simpson's rule on logarithmically graded intervals in x and in 2 - x.
  for (const float g : kGs) {
    const HenyeyGreenstein hg(g);
    const Vec3 wo(0, 0, 1);
    const auto f = [&](double x) { return double(hg.eval(wo, wiAt(x))); };
    std::vector<double> knots{0.0};
    for (double x = 1e-9; x < 1.0; x *= 1.05) knots.push_back(x);
    knots.push_back(1.0);
    for (double y = 1.0 / 1.05; y > 1e-9; y /= 1.05) knots.push_back(2.0 - y);
    knots.push_back(2.0);
    double integral = 0.0;
    for (size_t i = 0; i + 1 < knots.size(); ++i) {
      const double a = knots[i], b = knots[i + 1];
      constexpr int kSteps = 8;
      const double h = (b - a) / kSteps;
      double s = f(a) + f(b);
      for (int k = 1; k < kSteps; ++k) s += (k % 2 ? 4.0 : 2.0) * f(a + k * h);
      integral += s * h / 3.0;
    }
    EXPECT_NEAR(2 * M_PI * integral, 1.0, 1e-4) << "g = " << g;
  }
}

TEST(HenyeyGreenstein, EvalMatchesTheTextbookFormula) {
  for (const float g : kGs)
    for (double cosTheta = -1.0; cosTheta <= 1.0; cosTheta += 0.125) {
      const HenyeyGreenstein hg(g);
      const double ref = hgReference(g, cosTheta);
      EXPECT_NEAR(hg.eval(Vec3(0, 0, 1), wiAt(1 - cosTheta)), ref, 2e-5 * ref) << g << " " << cosTheta;
    }
}

TEST(HenyeyGreenstein, SamplingPassesChiSquare) {
  const Vec3 wo = glm::normalize(Vec3(0.3f, -0.5f, 0.8f));
  for (const float g : kGs) {
    const HenyeyGreenstein hg(g);
    test::Chi2Options options;
    options.sampleCount = 500000;
    const auto result = test::chi2Test(
        [&](Vec2 u, float) -> std::optional<Vec3> {
          const PhaseSample s = hg.sample(wo, u);
          // The reported pdf is the density at the returned direction.
          if (!(std::abs(s.pdf - hg.eval(wo, s.wi)) <= 1e-3f * s.pdf)) return Vec3(NAN);
          return s.wi;
        },
        [&](const Vec3& wi) { return hg.eval(wo, wi); }, options);
    EXPECT_TRUE(test::passes(result.pValue, 0.01, 4)) << "g = " << g << " p = " << result.pValue << "\n"
                                                      << result.histogramDump;
    EXPECT_NEAR(result.pdfIntegral, 1.0, 1e-3) << "g = " << g;
  }
}

TEST(HenyeyGreenstein, MeanCosineOfSamplesIsG) {
  const Vec3 wo = glm::normalize(Vec3(-1.0f, 2.0f, 0.5f));
  for (const float g : kGs) {
    const HenyeyGreenstein hg(g);
    test::UniformRng rng(7);
    constexpr int kN = 400000;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < kN; ++i) {
      const double c = -glm::dot(wo, hg.sample(wo, rng.next2()).wi);  // cos of the propagation angle
      sum += c, sum2 += c * c;
    }
    const double mean = sum / kN, sigma = std::sqrt((sum2 / kN - mean * mean) / kN);
    EXPECT_NEAR(mean, g, 3 * sigma + 1e-6) << "g = " << g;
    // The second moment is independent too: E[P2(cos)] = g^2, so E[cos^2] = (1 + 2 g^2) / 3.
    EXPECT_NEAR(sum2 / kN, (1 + 2.0 * g * g) / 3, 0.005) << "g = " << g;
  }
}

TEST(HenyeyGreenstein, SmallGAgreesWithTheIsotropicLimit) {
  // The textbook inverse (1 + g^2 - s^2) / (2 g) loses every digit as g -> 0 in float; the
  // factored form must give cos(theta) = 2 xi - 1 and p = 1 / 4 pi to O(g).
  for (const float g : {0.0f, 1e-7f, -1e-6f, 1e-5f, 1e-3f}) {
    const HenyeyGreenstein hg(g);
    for (float xi = 0.0f; xi <= 1.0f; xi += 0.0625f) {
      float oneMinus, onePlus;
      HenyeyGreenstein::sampleCos(g, xi, &oneMinus, &onePlus);
      EXPECT_NEAR(1.0f - oneMinus, 2.0f * xi - 1.0f, 2.0f * std::abs(g) + 1e-6f) << g << " " << xi;
      EXPECT_NEAR(onePlus - 1.0f, 2.0f * xi - 1.0f, 2.0f * std::abs(g) + 1e-6f) << g << " " << xi;
      const PhaseSample s = hg.sample(Vec3(0, 0, 1), Vec2(xi, 0.3f));
      EXPECT_NEAR(s.pdf, 1.0 / (4 * M_PI), (4.0 * std::abs(g) + 1e-6) / (4 * M_PI));
      EXPECT_NEAR(glm::length(s.wi), 1.0f, 1e-6f);
    }
  }
}

TEST(HenyeyGreenstein, NearOneTheSamplesStayValid) {
  // |g| -> 1: every sample a unit vector with a finite positive pdf equal to eval's.
  for (const float g : {0.999f, -0.999f, 0.9999f}) {
    const HenyeyGreenstein hg(g);
    test::UniformRng rng(3);
    for (int i = 0; i < 100000; ++i) {
      const Vec3 wo(0.0f, 0.6f, 0.8f);
      const PhaseSample s = hg.sample(wo, rng.next2());
      ASSERT_NEAR(glm::length(s.wi), 1.0f, 1e-5f);
      ASSERT_TRUE(std::isfinite(s.pdf) && s.pdf > 0.0f);
      ASSERT_NEAR(s.pdf, hg.eval(wo, s.wi), 2e-2f * s.pdf);
    }
  }
}

TEST(HenyeyGreenstein, ValidationNamesTheField) {
  for (const float g : {-1.0f, 1.0f, 1.5f, NAN, INFINITY}) {
    try {
      validateHenyeyGreensteinG(g, "scene.json", "media[0].g");
      ADD_FAILURE() << "accepted g = " << g;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "scene.json");
      EXPECT_NE(std::string(e.what()).find("media[0].g:"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(validateHenyeyGreensteinG(0.99f, "scene.json", "g"));
  EXPECT_NO_THROW(validateHenyeyGreensteinG(-0.5f, "scene.json", "g"));
}

}  // namespace
}  // namespace lensfarm
