// The environment light (light/environment_map.h): where each pixel of an equirectangular image
// is seen (checked against directions worked out by hand from the convention), rotation, the
// solid-angle density (integrates to 1, matches sample()), the estimator of the integral of the
// radiance, the constant mode, importance sampling against uniform sampling for a small sun,
// and the refusal of bad pixels naming the pixel and channel.
#include "common/light/environment_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "common/film/image_io.h"
#include "common/util/error.h"
#include "tests/support/uniform_rng.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

constexpr double kPiD = std::numbers::pi;
constexpr float kTop = 0x1.fffffep-1f;  // the largest float below 1
using Rng = test::UniformRng;

Image blankImage(int width, int height, float value = 0.0f) {
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.assign(3 * size_t(width) * size_t(height), value);
  return image;
}

void setPixel(Image& image, int x, int y, Spectrum s) {
  const size_t k = 3 * (size_t(y) * size_t(image.width) + size_t(x));
  image.rgb[k] = s.r;
  image.rgb[k + 1] = s.g;
  image.rgb[k + 2] = s.b;
}

// A sky-like map with structure in every channel: a gradient, noise, a black pixel, a black
// row and a bright spot.
Image randomishImage(int width, int height, uint32_t seed) {
  Image image = blankImage(width, height);
  Rng rng(seed);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float sky = 0.2f + 0.8f * float(height - y) / float(height);
      setPixel(image, x, y,
               Spectrum(sky * (0.5f + rng.next()), sky * (0.3f + rng.next()), 0.1f + 2.0f * rng.next() * rng.next()));
    }
  setPixel(image, 3, 2, Spectrum(0.0f));
  for (int x = 0; x < width; ++x) setPixel(image, x, height - 3, Spectrum(0.0f));
  setPixel(image, width / 3, height / 4, Spectrum(40.0f, 30.0f, 20.0f));
  return image;
}

// The exact solid angle of a pixel of row j: (2 pi / W) (cos(pi j / H) - cos(pi (j+1) / H)).
double pixelSolidAngle(int j, int width, int height) {
  return (2.0 * kPiD / width) * (std::cos(kPiD * j / height) - std::cos(kPiD * (j + 1) / height));
}

// The integral of the radiance over the sphere, from the pixels and their solid angles.
DVec3 analyticIntegral(const Image& image, double strength) {
  DVec3 sum(0.0);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) sum += DVec3(image.at(x, y)) * pixelSolidAngle(y, image.width, image.height);
  return sum * strength;
}

// Rotation about +y by the right-hand rule, written out here (not taken from the code).
Vec3 rotateAboutUp(const Vec3& d, double degrees) {
  const double a = degrees * kPiD / 180.0, c = std::cos(a), s = std::sin(a);
  return Vec3(float(c * d.x + s * d.z), d.y, float(-s * d.x + c * d.z));
}

TEST(EnvironmentMap, EachPixelIsSeenWhereTheConventionPutsIt) {
  // An 8 x 4 image whose pixel (i, j) holds the value 1 + i + 8 j in every channel: eval() of a
  // direction names the pixel it reads. The expected pixels are worked out by hand from the
  // convention (u = 0.5 + atan2(x, -z) / 2 pi, v = acos(y) / pi, row 0 at the top).
  Image image = blankImage(8, 4);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 8; ++i) setPixel(image, i, j, Spectrum(float(1 + i + 8 * j)));
  const EnvironmentMap env = EnvironmentMap::fromImage(image);
  struct Case {
    Vec3 d;
    int i, j;
    const char* what;
  } cases[] = {
      {{0.1f, 0.1f, -1.0f}, 4, 1, "just right of -z, just above the horizon: right of the centre (u > 0.5)"},
      {{-0.1f, 0.1f, -1.0f}, 3, 1, "just left of -z: left of the centre"},
      {{0.1f, -0.1f, -1.0f}, 4, 2, "just below the horizon: the row below the middle"},
      {{1.0f, 0.1f, -0.1f}, 5, 1, "+x, a little towards -z: u just below 0.75"},
      {{1.0f, 0.1f, 0.1f}, 6, 1, "+x, a little towards +z: u just above 0.75"},
      {{-1.0f, 0.1f, -0.1f}, 2, 1, "-x, a little towards -z: u just above 0.25"},
      {{0.1f, 0.1f, 1.0f}, 7, 1, "+z (behind), a little towards +x: the right edge"},
      {{-0.1f, 0.1f, 1.0f}, 0, 1, "+z, a little towards -x: the left edge"},
      {{0.3f, 1.0f, -0.2f}, 5, 0, "near the zenith: the top row"},
      {{0.3f, -1.0f, -0.2f}, 5, 3, "near the nadir: the bottom row"},
      {{1e-9f, 0.1f, 1.0f}, 7, 1, "a hair to the +x side of +z: still the right edge, though u rounds to 1"},
      {{-1e-9f, 0.1f, 1.0f}, 0, 1, "a hair to the -x side of +z: the left edge"},
  };
  for (const Case& c : cases)
    EXPECT_EQ(env.eval(c.d).r, float(1 + c.i + 8 * c.j)) << c.what << ": expected pixel (" << c.i << ", " << c.j << ")";
  EXPECT_LE(env.eval(Vec3(0, 1, 0)).r, 8.0f) << "straight up is in the top row";
  EXPECT_GE(env.eval(Vec3(0, -1, 0)).r, 25.0f) << "straight down is in the bottom row";

  // The convention's two maps, at points worked out by hand.
  const Vec2 centre = EnvironmentMap::directionToUv(Vec3(0, 0, -1));
  EXPECT_NEAR(centre.x, 0.5f, 1e-6f);
  EXPECT_NEAR(centre.y, 0.5f, 1e-6f);
  const Vec2 east = EnvironmentMap::directionToUv(Vec3(1, 0, 0));
  EXPECT_NEAR(east.x, 0.75f, 1e-6f);
  const Vec3 d = EnvironmentMap::uvToDirection(Vec2(0.625f, 0.25f));  // phi = 45 deg, theta = 45 deg
  EXPECT_NEAR(d.x, 0.5f, 1e-6f);
  EXPECT_NEAR(d.y, std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(d.z, -0.5f, 1e-6f);
}

// A 64 x 32 image, black but for pixel (48, 8): u in [0.75, 0.765625), v in [0.25, 0.28125),
// i.e. phi in [90, 95.625) degrees and theta in [45, 50.625) degrees. By hand:
// x = sin(theta) sin(phi) in [0.7037, 0.7731], y = cos(theta) in (0.6343, 0.7072], z = -sin(theta)
// cos(phi) in [0, 0.0758]: to the right (+x), 39-45 degrees up, a little behind (+z).
Image onePixelImage() {
  Image image = blankImage(64, 32);
  setPixel(image, 48, 8, Spectrum(100.0f));
  return image;
}

TEST(EnvironmentMap, ABrightPixelIsSampledInTheDirectionWorkedOutByHand) {
  const EnvironmentMap env = EnvironmentMap::fromImage(onePixelImage());
  Rng rng(1);
  Vec3 mean(0.0f);
  for (int k = 0; k < 4000; ++k) {
    const auto s = env.sample(rng.next2());
    ASSERT_TRUE(s.has_value());
    ASSERT_TRUE(s->wi.x >= 0.7036f && s->wi.x <= 0.7732f) << s->wi.x;
    ASSERT_TRUE(s->wi.y > 0.6343f && s->wi.y <= 0.7072f) << s->wi.y;
    ASSERT_TRUE(s->wi.z >= -1e-6f && s->wi.z <= 0.0758f) << s->wi.z;
    ASSERT_EQ(s->radiance, Spectrum(100.0f));
    mean += s->wi / 4000.0f;
  }
  EXPECT_GT(mean.z, 0.01f) << "the samples spread over the pixel, not its corner";
  EXPECT_EQ(env.pdf(Vec3(0, 0, -1)), 0.0f) << "black pixels have density 0";
  EXPECT_EQ(env.eval(Vec3(-0.74f, 0.67f, 0.03f)), Spectrum(0.0f)) << "the mirror image (-x) is black";
}

TEST(EnvironmentMap, RotationTurnsTheSkyCounterClockwiseAboutUp) {
  // +90 degrees by the right-hand rule about +y: (x, y, z) -> (z, y, -x). The bright pixel,
  // to the right (+x), moves to the front (-z): x in [0, 0.0758], z in [-0.7731, -0.7037].
  const EnvironmentMap env = EnvironmentMap::fromImage(onePixelImage(), 1.0f, 90.0f);
  Rng rng(2);
  for (int k = 0; k < 2000; ++k) {
    const auto s = env.sample(rng.next2());
    ASSERT_TRUE(s.has_value());
    ASSERT_TRUE(s->wi.x >= -1e-6f && s->wi.x <= 0.0758f) << s->wi.x;
    ASSERT_TRUE(s->wi.y > 0.6343f && s->wi.y <= 0.7072f) << s->wi.y;
    ASSERT_TRUE(s->wi.z >= -0.7732f && s->wi.z <= -0.7036f) << s->wi.z;
  }
  // For any angle, the rotated map seen along R d is the unrotated map seen along d, for the
  // centre of every pixel of a map whose pixels differ (far from the pixels' edges).
  const Image image = randomishImage(24, 12, 5);
  const EnvironmentMap plain = EnvironmentMap::fromImage(image);
  for (const double degrees : {90.0, -90.0, 37.0, 360.0}) {
    const EnvironmentMap turned = EnvironmentMap::fromImage(image, 1.0f, float(degrees));
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 24; ++i) {
        const Vec3 d = EnvironmentMap::uvToDirection(Vec2((float(i) + 0.5f) / 24.0f, (float(j) + 0.5f) / 12.0f));
        const Vec3 r = rotateAboutUp(d, degrees);
        ASSERT_EQ(turned.eval(r), plain.eval(d)) << degrees << " degrees, pixel " << i << ", " << j;
        ASSERT_NEAR(turned.pdf(r), plain.pdf(d), 1e-4f * plain.pdf(d)) << degrees << " degrees";
      }
  }
}

TEST(EnvironmentMap, SolidAngleDensityIntegratesToOneOverTheSphere) {
  // Midpoint quadrature in spherical coordinates of the test's own (phi from +x): the integral
  // of pdf(d) sin(theta) dtheta dphi. Within a pixel pdf sin(theta) is constant, and the grid has
  // 25 x 25 cells per pixel of the 48 x 24 map: its theta edges fall on the pixels' edges, and
  // all the pixels' phi edges sit at the same offset inside a grid cell, whatever the rotation,
  // so the midpoint errors at the phi edges cancel around the circle. The rule is exact up to
  // rounding (measured ~1e-7; a grid not nested in the pixels errs by ~2e-3).
  const Image image = randomishImage(48, 24, 9);
  for (const float rotation : {0.0f, 10.0f}) {
    const EnvironmentMap env = EnvironmentMap::fromImage(image, 1.5f, rotation);
    const int nt = 600, np = 1200;
    double integral = 0.0;
    for (int a = 0; a < nt; ++a) {
      const double theta = kPiD * (a + 0.5) / nt, st = std::sin(theta);
      for (int b = 0; b < np; ++b) {
        const double phi = 2.0 * kPiD * (b + 0.5) / np;
        const Vec3 d(float(st * std::cos(phi)), float(std::cos(theta)), float(st * std::sin(phi)));
        integral += double(env.pdf(d)) * st;
      }
    }
    integral *= (kPiD / nt) * (2.0 * kPiD / np);
    EXPECT_NEAR(integral, 1.0, 1e-5) << "rotation " << rotation;
  }
  const EnvironmentMap constant = EnvironmentMap::constant(Spectrum(1.0f));
  EXPECT_FLOAT_EQ(constant.pdf(Vec3(0.3f, -0.2f, 0.9f)) * 4.0f * float(kPiD), 1.0f);
}

TEST(EnvironmentMap, ASampleCarriesTheRadianceAndDensityOfItsDirection) {
  const EnvironmentMap env = EnvironmentMap::fromImage(randomishImage(48, 24, 13), 2.0f, 30.0f);
  std::vector<Vec2> us = {Vec2(0, 0), Vec2(0, kTop), Vec2(kTop, 0), Vec2(kTop, kTop), Vec2(0.5f, 0), Vec2(0.5f, kTop)};
  Rng rng(3);
  for (int k = 0; k < 20000; ++k) us.push_back(rng.next2());
  int refused = 0;
  for (const Vec2 u : us) {
    const auto s = env.sample(u);
    if (!s) {
      ++refused;
      continue;
    }
    ASSERT_NEAR(glm::length(s->wi), 1.0f, 1e-5f);
    ASSERT_EQ(s->radiance, env.eval(s->wi)) << "radiance is eval(wi)";
    ASSERT_NEAR(s->pdf, env.pdf(s->wi), 1e-4f * s->pdf) << "pdf is pdf(wi)";
    ASSERT_GT(s->pdf, 0.0f);
    ASSERT_GT(luminance(s->radiance), 0.0f) << "a black pixel was sampled";
  }
  EXPECT_LE(refused, 3) << "only samples at the zenith (v == 0, here u.y == 0) are refused";
}

TEST(EnvironmentMap, EstimatorConvergesToTheIntegralOfTheRadiance) {
  // E[eval(wi) / pdf(wi)] = integral of L over the sphere = sum of L_ij times the pixel's solid
  // angle (2 pi / W)(cos theta_j - cos theta_{j+1}).
  const Image image = randomishImage(48, 24, 17);
  const float strength = 1.5f;
  const EnvironmentMap env = EnvironmentMap::fromImage(image, strength, 30.0f);
  const DVec3 exact = analyticIntegral(image, strength);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(env.integral()[c], exact[c], 1e-5 * exact[c]) << "channel " << c;
  EXPECT_NEAR(env.integralLuminance(), 0.2126 * exact.x + 0.7152 * exact.y + 0.0722 * exact.z, 1e-5 * exact.y);

  const int n = 100000;
  DVec3 sum(0.0), sumSq(0.0);
  Rng rng(4);
  for (int k = 0; k < n; ++k) {
    const auto s = env.sample(rng.next2());
    if (!s) continue;
    const DVec3 f = DVec3(s->radiance) / double(s->pdf);
    sum += f;
    sumSq += f * f;
  }
  for (int c = 0; c < 3; ++c) {
    const double mean = sum[c] / n, sigma = std::sqrt((sumSq[c] / n - mean * mean) / n);
    EXPECT_NEAR(mean, exact[c], 4.0 * sigma) << "channel " << c;
    EXPECT_NEAR(mean, exact[c], 0.01 * exact[c]) << "channel " << c;
  }
}

TEST(EnvironmentMap, ConstantRadianceIntegratesToFourPiL) {
  const Spectrum l(0.2f, 0.5f, 1.5f);
  const EnvironmentMap env = EnvironmentMap::constant(l);
  EXPECT_TRUE(env.isConstant());
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(env.integral()[c], float(4.0 * kPiD * l[c]));
  EXPECT_FLOAT_EQ(env.integralLuminance(), float(4.0 * kPiD * luminance(l)));
  Rng rng(6);
  double meanY = 0.0, meanY2 = 0.0, meanX = 0.0;
  const int n = 40000;
  for (int k = 0; k < n; ++k) {
    const auto s = env.sample(rng.next2());
    ASSERT_TRUE(s.has_value());
    ASSERT_NEAR(glm::length(s->wi), 1.0f, 1e-5f);
    ASSERT_EQ(s->radiance, l);
    ASSERT_EQ(s->radiance, env.eval(s->wi));
    ASSERT_EQ(s->pdf, env.pdf(s->wi));
    for (int c = 0; c < 3; ++c)
      ASSERT_NEAR(s->radiance[c] / s->pdf, 4.0 * kPiD * l[c], 1e-5) << "every sample is exact";
    meanX += s->wi.x / n;
    meanY += s->wi.y / n;
    meanY2 += s->wi.y * s->wi.y / n;
  }
  // Uniform on the sphere: E[x] = E[y] = 0, E[y^2] = 1/3 (standard errors 0.003 and 0.0015).
  EXPECT_NEAR(meanX, 0.0, 0.015);
  EXPECT_NEAR(meanY, 0.0, 0.015);
  EXPECT_NEAR(meanY2, 1.0 / 3.0, 0.008);
}

TEST(EnvironmentMap, ImagesFromOnePixelUpGiveTheirIntegral) {
  // 1 x 1 is a constant sky sampled in (u, v): eval / pdf = 2 pi^2 sin(theta) L, whose mean over
  // theta uniform in [0, pi] is 4 pi L. Thin and odd sizes, and a 2048 x 1024 map.
  const Spectrum l(0.25f, 0.5f, 1.0f);
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {1, 2}, {2, 1}, {3, 5}, {7, 3}}) {
    Image image = blankImage(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) setPixel(image, x, y, l * float(1 + x + 2 * y));
    const EnvironmentMap env = EnvironmentMap::fromImage(image);
    const DVec3 exact = analyticIntegral(image, 1.0);
    if (w == 1 && h == 1) {
      EXPECT_NEAR(exact.z, 4.0 * kPiD, 1e-12);
    }
    EXPECT_NEAR(env.integral().z, exact.z, 1e-5 * exact.z);
    Rng rng(uint32_t(w * 100 + h));
    double sum = 0.0, sumSq = 0.0;
    const int n = 40000;
    for (int k = 0; k < n; ++k) {
      const auto s = env.sample(rng.next2());
      ASSERT_TRUE(s.has_value());
      ASSERT_EQ(s->radiance, env.eval(s->wi));
      ASSERT_NEAR(s->pdf, env.pdf(s->wi), 1e-4f * s->pdf);
      const double f = s->radiance.b / s->pdf;
      sum += f;
      sumSq += f * f;
    }
    const double mean = sum / n, sigma = std::sqrt((sumSq / n - mean * mean) / n);
    EXPECT_NEAR(mean, exact.z, 4.0 * sigma + 1e-9) << w << " x " << h;
  }
  Image big = blankImage(2048, 1024, 0.5f);
  setPixel(big, 2047, 1023, Spectrum(1000.0f));
  const EnvironmentMap env = EnvironmentMap::fromImage(big);
  const auto corner = env.sample(Vec2(kTop, kTop));
  ASSERT_TRUE(corner.has_value());
  EXPECT_EQ(corner->radiance, Spectrum(1000.0f)) << "u just below 1 reaches the last pixel";
  EXPECT_NEAR(env.integral().x, analyticIntegral(big, 1.0).x, 1e-5 * env.integral().x);
}

TEST(EnvironmentMap, ImportanceSamplingBeatsUniformSphereSamplingForASmallSun) {
  // A 256 x 128 sky of 0.1 with a 2 x 2 pixel sun of 1e4, 31-34 degrees above the horizon (rows 40-41).
  // The irradiance on an upward-facing plane, E = integral of L max(0, cos theta) d omega, is
  // sum of L_ij (2 pi / W) (sin^2 theta_{j+1} - sin^2 theta_j) / 2 over the rows above the horizon.
  // Both estimators use N = 64 samples per run over 1000 runs; the RMS error of a run times
  // sqrt(N) is the error per sample. Measured with this seed: importance 2.18, uniform 522, a
  // ratio of 240. Uniform samples hit the sun (1.6e-4 of the sphere) only ~10 times in 64000,
  // so its measured error is itself noisy and low: 30000 runs give 857 (the exact standard
  // deviation, sqrt(4 pi integral of (L cos)^2 - E^2), is 855.5) against 2.23, a ratio of 384.
  // Even with no sun hit at all the uniform error would be ~E sqrt(N) = 87, still 40x.
  const int w = 256, h = 128;
  Image image = blankImage(w, h, 0.1f);
  for (int y = 40; y < 42; ++y)
    for (int x = 160; x < 162; ++x) setPixel(image, x, y, Spectrum(1e4f));
  const EnvironmentMap env = EnvironmentMap::fromImage(image);
  double exact = 0.0;
  for (int y = 0; y < h / 2; ++y) {
    const double s0 = std::sin(kPiD * y / h), s1 = std::sin(kPiD * (y + 1) / h);
    for (int x = 0; x < w; ++x) exact += luminance(image.at(x, y)) * (2.0 * kPiD / w) * (s1 * s1 - s0 * s0) / 2.0;
  }
  auto irradianceTerm = [&](const Vec3& wi, double pdf) {
    return double(luminance(env.eval(wi))) * std::max(0.0, double(wi.y)) / pdf;
  };
  const int runs = 1000, n = 64;
  Rng rng(8);
  double squaredImportance = 0.0, squaredUniform = 0.0;
  for (int r = 0; r < runs; ++r) {
    double importance = 0.0, uniform = 0.0;
    for (int k = 0; k < n; ++k) {
      if (const auto s = env.sample(rng.next2())) importance += irradianceTerm(s->wi, s->pdf);
      // Uniform on the sphere, written here: y uniform in [-1, 1], pdf 1 / (4 pi).
      const float y = 1.0f - 2.0f * rng.next(), phi = 2.0f * float(kPiD) * rng.next();
      const float rxz = std::sqrt(std::max(0.0f, 1.0f - y * y));
      uniform += irradianceTerm(Vec3(rxz * std::cos(phi), y, rxz * std::sin(phi)), 1.0 / (4.0 * kPiD));
    }
    squaredImportance += std::pow(importance / n - exact, 2) / runs;
    squaredUniform += std::pow(uniform / n - exact, 2) / runs;
  }
  const double errImportance = std::sqrt(squaredImportance * n), errUniform = std::sqrt(squaredUniform * n);
  std::printf("[ sun sky ] E = %.4f; RMS error per sample: importance %.3f, uniform %.3f, ratio %.1f\n", exact,
              errImportance, errUniform, errUniform / errImportance);
  EXPECT_GT(errUniform, 10.0 * errImportance);
  EXPECT_LT(errImportance, 0.5 * exact) << "the importance-sampled estimate is itself accurate";
}

TEST(EnvironmentMap, ValidateNamesTheBadPixelAndChannel) {
  Image image = blankImage(16, 8, 0.5f);
  EXPECT_FALSE(EnvironmentMap::validate(image).has_value());
  auto bad = [&](int x, int y, int c, float value) {
    Image copy = image;
    copy.rgb[3 * (size_t(y) * 16 + size_t(x)) + size_t(c)] = value;
    return EnvironmentMap::validate(copy).value_or("(accepted)");
  };
  EXPECT_EQ(bad(12, 7, 0, std::nanf("")), "pixel (12, 7) red is NaN");
  EXPECT_EQ(bad(3, 1, 1, INFINITY), "pixel (3, 1) green is infinite (+inf)");
  EXPECT_EQ(bad(0, 0, 2, -INFINITY), "pixel (0, 0) blue is infinite (-inf)");
  EXPECT_EQ(bad(15, 0, 2, -0.5f), "pixel (15, 0) blue is negative (-0.5)");
  EXPECT_FALSE(EnvironmentMap::validate([&] {
                 Image z = image;
                 z.rgb[5] = -0.0f;
                 return z;
               }())
                   .has_value())
      << "-0 is zero, not negative";

  Image empty;
  EXPECT_NE(EnvironmentMap::validate(empty).value_or("").find("0 x 0"), std::string::npos);
  Image ragged = image;
  ragged.rgb.pop_back();
  EXPECT_NE(EnvironmentMap::validate(ragged).value_or("").find("383 values for 16 x 8"), std::string::npos);

  Image nan = image;
  nan.rgb[3 * (7 * 16 + 12)] = std::nanf("");
  try {
    (void)EnvironmentMap::fromImage(nan);
    ADD_FAILURE() << "a NaN pixel was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "environment: pixel (12, 7) red is NaN");
  }
  EXPECT_THROW((void)EnvironmentMap::fromImage(image, -1.0f), InputError);
  EXPECT_THROW((void)EnvironmentMap::fromImage(image, std::nanf("")), InputError);
  EXPECT_THROW((void)EnvironmentMap::fromImage(image, 1.0f, INFINITY), InputError);
  EXPECT_THROW((void)EnvironmentMap::fromImage(blankImage(2, 1, 3e38f), 10.0f), InputError) << "overflow";
  EXPECT_THROW((void)EnvironmentMap::constant(Spectrum(1.0f, -1.0f, 1.0f)), InputError);
  EXPECT_THROW((void)EnvironmentMap::constant(Spectrum(1.0f, 1.0f, std::nanf(""))), InputError);
}

TEST(EnvironmentMap, StrengthScalesTheRadianceButNotTheDensity) {
  const Image image = randomishImage(32, 16, 21);
  const EnvironmentMap one = EnvironmentMap::fromImage(image, 1.0f), three = EnvironmentMap::fromImage(image, 3.0f);
  Rng rng(12);
  for (int k = 0; k < 200; ++k) {
    const auto a = one.sample(rng.next2());
    ASSERT_TRUE(a.has_value());
    ASSERT_NEAR(three.pdf(a->wi), a->pdf, 1e-5f * a->pdf);
    for (int c = 0; c < 3; ++c) ASSERT_FLOAT_EQ(three.eval(a->wi)[c], 3.0f * a->radiance[c]);
  }
  EXPECT_NEAR(three.integralLuminance(), 3.0f * one.integralLuminance(), 1e-5f * three.integralLuminance());
  const EnvironmentMap off = EnvironmentMap::fromImage(image, 0.0f);
  EXPECT_EQ(off.integralLuminance(), 0.0f);
  EXPECT_EQ(off.eval(Vec3(0, 1, 0)), Spectrum(0.0f));
}

TEST(EnvironmentMap, AnExrFileKeepsItsOrientation) {
  // The scene loader reads the file with readExr (row 0 at the top) and calls fromImage: the
  // bright pixel of onePixelImage() is still seen to the right (+x), 40-45 degrees up.
  test::TempDir dir;
  writeExr(dir / "sky.exr", onePixelImage(), ImageMetadata{});
  const Image read = readExr(dir / "sky.exr");
  ASSERT_FALSE(EnvironmentMap::validate(read).has_value());
  const EnvironmentMap env = EnvironmentMap::fromImage(read);
  const auto s = env.sample(Vec2(0.5f, 0.5f));
  ASSERT_TRUE(s.has_value());
  EXPECT_TRUE(s->wi.x > 0.7036f && s->wi.y > 0.6343f && s->wi.y <= 0.7072f)
      << s->wi.x << ", " << s->wi.y << ", " << s->wi.z;
}

}  // namespace
}  // namespace lensfarm
