// The warps' polynomial sine and cosine against the library's, over the whole unit square.
#include <gtest/gtest.h>

#include <cmath>

#include "math/sampling.h"

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

}  // namespace
}  // namespace lensfarm
