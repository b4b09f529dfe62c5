// The warps' polynomial sine and cosine against the library's, over the whole unit square.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "common/math/sampling.h"

namespace lensfarm {
namespace {

TEST(Warps, PolynomialSinCosMatchesTheLibraryOnItsRange) {
  float worst = 0.0f;
  for (int k = -100000; k <= 100000; ++k) {
    const float x = (kPi / 4.0f) * float(k) / 100000.0f;
    float s, c;
    sinCosQuarterPi(x, s, c);
    worst = std::max({worst, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
  }
  EXPECT_LT(worst, 2.5e-7f) << "within about two ulps of values up to 1";
}

TEST(Warps, ConcentricDiskMatchesTheTrigonometricMapAndStaysInTheDisk) {
  // The Shirley-Chiu map written with std::cos and std::sin, as in pbrt.
  auto reference = [](Vec2 u) {
    const Vec2 o = 2.0f * u - Vec2(1.0f);
    if (o.x == 0.0f && o.y == 0.0f) return Vec2(0.0f);
    float r, theta;
    if (std::abs(o.x) > std::abs(o.y)) {
      r = o.x;
      theta = (kPi / 4.0f) * (o.y / o.x);
    } else {
      r = o.y;
      theta = kPi / 2.0f - (kPi / 4.0f) * (o.x / o.y);
    }
    return r * Vec2(std::cos(theta), std::sin(theta));
  };
  float worst = 0.0f;
  const int n = 600;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const Vec2 u(std::min(float(i) / n, 0x1.fffffep-1f), std::min(float(j) / n, 0x1.fffffep-1f));
      const Vec2 d = sampleConcentricDisk(u), e = reference(u);
      worst = std::max(worst, glm::length(d - e));
      ASSERT_LE(glm::dot(d, d), 1.0f + 1e-6f) << u.x << ", " << u.y;
      const Vec3 w = sampleCosineHemisphere(u);
      ASSERT_GE(w.z, 0.0f);
      ASSERT_NEAR(glm::length(w), 1.0f, 1e-5f);
    }
  EXPECT_LT(worst, 5e-7f);
}

TEST(Warps, EveryPointOfTheSquareIncludingItsRimGivesADirectionAboveTheHorizon) {
  // u.x or u.y exactly 0 maps to the disk's rim: z was 0, a horizon direction of pdf 0 that the
  // integrator dropped without a word. Every u in [0,1)^2 must give z > 0, a unit direction and a
  // positive pdf, so the weight f cos / pdf = albedo holds.
  const float top = 0x1.fffffep-1f;  // the largest float below 1
  std::vector<Vec2> us = {Vec2(0.0f, 0.0f),      Vec2(0.0f, 0.5f),      Vec2(0.5f, 0.0f),
                          Vec2(0.0f, 0.999999f), Vec2(0.999999f, 0.0f), Vec2(0.0f, top),
                          Vec2(top, 0.0f),       Vec2(top, top),        Vec2(0x1.0p-24f, 0.5f)};
  for (int k = 0; k <= 4096; ++k) {  // the whole rim, and the samplers' 24-bit values next to it
    const float t = std::min(float(k) / 4096.0f, top);
    for (const Vec2 u : {Vec2(0.0f, t), Vec2(t, 0.0f), Vec2(0x1.0p-24f, t), Vec2(t, 0x1.0p-24f)}) us.push_back(u);
  }
  for (const Vec2 u : us) {
    const Vec3 w = sampleCosineHemisphere(u);
    ASSERT_TRUE(std::isfinite(w.x) && std::isfinite(w.y) && std::isfinite(w.z)) << u.x << ", " << u.y;
    ASSERT_GT(w.z, 0.0f) << u.x << ", " << u.y;
    ASSERT_NEAR(glm::length(w), 1.0f, 1e-6f) << u.x << ", " << u.y;
    ASSERT_GT(cosineHemispherePdf(w.z), 0.0f) << u.x << ", " << u.y;
  }
}

TEST(Warps, InteriorSamplesKeepTheirDirectionBitForBit) {
  // The rim fix changes only samples whose height was 0: every other direction is the plain
  // Malley warp, bit for bit, so images keep their bits.
  for (int i = 1; i < 512; ++i)
    for (int j = 1; j < 512; ++j) {
      const Vec2 u(float(i) / 512.0f, float(j) / 512.0f);
      const Vec2 d = sampleConcentricDisk(u);
      const float z = std::sqrt(std::max(0.0f, 1.0f - d.x * d.x - d.y * d.y));
      if (!(z > 0.0f)) continue;
      const Vec3 w = sampleCosineHemisphere(u);
      ASSERT_EQ(std::memcmp(&w, &d, sizeof(Vec2)), 0);
      ASSERT_EQ(w.z, z);
    }
}

}  // namespace
}  // namespace lensfarm
