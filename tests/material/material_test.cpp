// Materials: sampling densities (chi-square), energy of the rippled mirror, directions stay above
// the surface.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/material/material.h"
#include "common/material/mirror.h"
#include "common/math/sampling.h"

namespace lensfarm {
namespace {

// Upper 1 % point of the chi-square distribution with k degrees of freedom (Wilson-Hilferty).
double chiSquareCritical99(int k) {
  const double z = 2.3263478740;  // standard normal 99th percentile
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

TEST(Lambertian, SampledDirectionsFollowTheCosineDensity) {
  // Under pdf = cos(theta) / pi, both cos^2(theta) and phi are uniform on their ranges, so an
  // equal grid over (cos^2 theta, phi) has equal expected counts. The test derives this from the
  // density, independently of the warp in math/sampling.cpp.
  const Material m("diffuse", std::make_shared<LambertianBsdf>(Spectrum(0.6f, 0.3f, 0.1f)));
  const Vec3 n = glm::normalize(Vec3(1.0f, -2.0f, 3.0f));
  const Frame frame = Frame::fromNormal(n);
  const Vec3 wo = glm::normalize(n + Vec3(0.3f, 0.1f, 0.0f));
  constexpr int kCos = 16, kPhi = 32, kN = 1'000'000;
  std::vector<double> counts(kCos * kPhi, 0.0);
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < kN; ++k) {
    const auto s = m.sample(n, wo, 0.5f, Vec2(u(rng), u(rng)));
    ASSERT_TRUE(s.has_value());
    const Vec3 local = frame.toLocal(s->wi);
    ASSERT_GT(local.z, 0.0f);
    // The weight f cos / pdf of a cosine-sampled Lambertian is its albedo exactly.
    ASSERT_NEAR(s->weight.r, 0.6f, 1e-6f);
    ASSERT_NEAR(s->pdf, m.pdf(n, wo, s->wi), 1e-4f * s->pdf);
    const double c2 = std::min(0.999999, double(local.z) * local.z);
    const double phi = std::atan2(double(local.y), double(local.x)) + M_PI;
    const int a = int(c2 * kCos), b = std::min(kPhi - 1, int(phi / (2 * M_PI) * kPhi));
    counts[a * kPhi + b] += 1.0;
  }
  const double expected = double(kN) / (kCos * kPhi);
  double chi2 = 0.0;
  for (double c : counts) chi2 += (c - expected) * (c - expected) / expected;
  EXPECT_LT(chi2, chiSquareCritical99(kCos * kPhi - 1));
}

TEST(Lambertian, ASampleOnTheRimOfTheUnitSquareStillGivesADirection) {
  // u.x or u.y exactly 0 used to give no direction (a horizon ray of pdf 0): the path ended
  // silently. Now it leaves just above the horizon, with weight = albedo and pdf = cos / pi.
  const Material m("diffuse", std::make_shared<LambertianBsdf>(Spectrum(0.6f, 0.3f, 0.1f)));
  const Vec3 n = glm::normalize(Vec3(1.0f, -2.0f, 3.0f));
  for (const Vec2 u : {Vec2(0.0f, 0.0f), Vec2(0.0f, 0.5f), Vec2(0.5f, 0.0f), Vec2(0.0f, 0.999999f)}) {
    const auto s = m.sampleLambertian(n, u);
    ASSERT_TRUE(s.has_value()) << u.x << ", " << u.y;
    const float cosTheta = glm::dot(n, s->wi);
    EXPECT_GT(cosTheta, 0.0f);
    EXPECT_NEAR(glm::length(s->wi), 1.0f, 1e-6f);
    EXPECT_GT(s->pdf, 0.0f);
    EXPECT_NEAR(s->pdf, m.pdf(n, n, s->wi), 1e-2f * s->pdf);  // the world frame rounds a 2^-12 cosine
    EXPECT_EQ(s->weight, m.albedo());
  }
}

TEST(Lambertian, EvalCosIntegratesToTheAlbedo) {
  // Monte Carlo with uniform hemisphere directions (not the material's own sampler).
  const Material m("diffuse", std::make_shared<LambertianBsdf>(Spectrum(0.8f)));
  const Vec3 n(0, 0, 1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double sum = 0.0;
  const int kN = 400000;
  for (int k = 0; k < kN; ++k) {
    const double z = u(rng), phi = 2 * M_PI * u(rng), r = std::sqrt(1 - z * z);
    const Vec3 wi(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
    sum += m.evalCos(n, n, wi).r * (2 * M_PI);  // divide by the uniform pdf 1 / 2pi
  }
  EXPECT_NEAR(sum / kN, 0.8, 0.005);
}

TEST(RippledMirror, KeepsExactlyItsReflectanceAndNeverGoesBelowTheSurface) {
  // A strong ripple, so grazing reflections would dip below the surface.
  const Material m("rippled", std::make_shared<RippledMirrorBsdf>(Spectrum(0.5f), 0.3f));
  const Vec3 n = glm::normalize(Vec3(0.2f, 1.0f, -0.4f));
  const Frame frame = Frame::fromNormal(n);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (double degrees : {0.0, 30.0, 60.0, 85.0, 89.0, 89.99}) {
    const double theta = degrees * M_PI / 180.0;
    const Vec3 wo = frame.toWorld(Vec3(float(std::sin(theta)), 0.0f, float(std::cos(theta))));
    double energy = 0.0;
    const int kN = 20000;
    for (int k = 0; k < kN; ++k) {
      const auto s = m.sample(n, wo, 0.5f, Vec2(u(rng), u(rng)));
      ASSERT_TRUE(s.has_value()) << "a mirror must never lose a ray";
      ASSERT_TRUE(s->specular);
      ASSERT_GE(glm::dot(s->wi, n), 0.0f) << "at " << degrees << " degrees";
      ASSERT_NEAR(glm::length(s->wi), 1.0f, 1e-5f);
      energy += s->weight.g;
    }
    EXPECT_NEAR(energy / kN, 0.5, 1e-6) << "the seed's attenuation 0.5 and nothing else";
  }
}

TEST(RippledMirror, SpreadsAroundThePerfectReflectionByTheRipple) {
  Material m;
  const Vec3 n(0, 0, 1);
  const Vec3 wo = glm::normalize(Vec3(1.0f, 0.0f, 1.0f));
  const Vec3 mirror = glm::normalize(Vec3(-1.0f, 0.0f, 1.0f));
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (float ripple : {0.0f, 0.01f, 0.05f}) {
    m = Material("rippled", std::make_shared<RippledMirrorBsdf>(Spectrum(1.0f), ripple));
    float maxAngle = 0.0f;
    for (int k = 0; k < 5000; ++k) {
      const auto s = m.sample(n, wo, 0.5f, Vec2(u(rng), u(rng)));
      maxAngle = std::max(maxAngle, std::acos(std::min(1.0f, glm::dot(s->wi, mirror))));
    }
    // Tilting the normal by atan(ripple) turns the reflection by at most twice that.
    EXPECT_LE(maxAngle, 2.0f * std::atan(ripple) + 1e-3f) << "ripple " << ripple;
    if (ripple > 0) {
      EXPECT_GT(maxAngle, 1.5f * std::atan(ripple)) << "ripple " << ripple;
    }
  }
}

TEST(RippledMirror, TiltsItsNormalUniformlyOverTheDiskOfSlopes) {
  // The model: the normal is tilted by a slope drawn uniformly from the disk of radius `ripple`.
  // From each sampled reflection the tilted normal is recovered as the half vector of wo and wi
  // (no folding happens for wo = n and ripple 0.3); its slope must be uniform in the disk, so an
  // equal-area grid over (slope^2 / ripple^2, angle) has equal expected counts.
  const Material m("rippled", std::make_shared<RippledMirrorBsdf>(Spectrum(0.5f), 0.3f));
  const Vec3 n = glm::normalize(Vec3(0.3f, -1.0f, 0.2f));
  const Frame frame = Frame::fromNormal(n);
  constexpr int kRadial = 10, kAngular = 20, kN = 400000;
  std::vector<double> counts(kRadial * kAngular, 0.0);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < kN; ++k) {
    const auto s = m.sample(n, n, 0.5f, Vec2(u(rng), u(rng)));
    const Vec3 h = frame.toLocal(glm::normalize(n + s->wi));
    const double sx = h.x / h.z, sy = h.y / h.z;
    const double r2 = (sx * sx + sy * sy) / (0.3 * 0.3);
    ASSERT_LE(r2, 1.0 + 1e-4);
    const double phi = std::atan2(sy, sx) + M_PI;
    const int a = std::min(kRadial - 1, int(r2 * kRadial)),
              b = std::min(kAngular - 1, int(phi / (2 * M_PI) * kAngular));
    counts[a * kAngular + b] += 1.0;
  }
  const double expected = double(kN) / (kRadial * kAngular);
  double chi2 = 0.0;
  for (double c : counts) chi2 += (c - expected) * (c - expected) / expected;
  EXPECT_LT(chi2, chiSquareCritical99(kRadial * kAngular - 1));
}

TEST(Mirror, ReflectsAboutTheNormal) {
  const Material m("mirror", std::make_shared<MirrorBsdf>(Spectrum(0.9f)));
  const Vec3 n(0, 1, 0), wo = glm::normalize(Vec3(1, 2, 3));
  const auto s = m.sample(n, wo, 0.5f, Vec2(0.3f, 0.7f));
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(s->wi.x, -wo.x, 1e-6f);
  EXPECT_NEAR(s->wi.y, wo.y, 1e-6f);
  EXPECT_NEAR(s->wi.z, -wo.z, 1e-6f);
  EXPECT_FLOAT_EQ(s->weight.r, 0.9f);
  EXPECT_EQ(m.evalCos(n, wo, s->wi), Spectrum(0.0f));  // delta lobes are never evaluated
}

}  // namespace
}  // namespace lensfarm
