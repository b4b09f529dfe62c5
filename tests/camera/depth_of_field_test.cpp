// Depth of field: the 2013 report's Table 1 and the textbook formulas' behaviour at the hyperfocal distance.
#include <gtest/gtest.h>

#include <cmath>

#include "common/camera/depth_of_field.h"

namespace lensfarm {
namespace {

constexpr double kF = 0.095, kS1 = 2.9, kL = 0.1;

double round3(double x) { return std::round(x * 1000.0) / 1000.0; }

TEST(DepthOfField, ReproducesSeedTable1ToThreeDecimals) {
  struct Row {
    double n, h, dn, df, depth;
  };
  // 2013 report, Table 1 (S1 = 2.9, f = 0.095, L = 0.1, c = sqrt(2) L / 1500).
  const Row table[] = {{2, 47.957, 2.740, 3.093, 0.353},
                       {4, 24.026, 2.597, 3.313, 0.716},
                       {8, 12.061, 2.353, 3.858, 1.505},
                       {16, 6.078, 1.984, 5.717, 3.733},
                       {32, 3.086, 1.519, 97.934, 96.415}};
  const double c = circleOfConfusion(kL, kL);
  EXPECT_NEAR(c, std::sqrt(2.0) * kL / 1500.0, 1e-15);
  for (const Row& r : table) {
    const DepthOfField d = seedDepthOfField(kF, kS1, r.n, c);
    EXPECT_DOUBLE_EQ(round3(d.hyperfocal), r.h) << "N = " << r.n;
    EXPECT_DOUBLE_EQ(round3(d.nearLimit), r.dn) << "N = " << r.n;
    EXPECT_DOUBLE_EQ(round3(d.farLimit), r.df) << "N = " << r.n;
    EXPECT_DOUBLE_EQ(round3(d.depth()), r.depth) << "N = " << r.n;
  }
}

TEST(DepthOfField, FarLimitIsInfiniteAtAndBeyondTheHyperfocalDistance) {
  const double c = circleOfConfusion(kL, kL);
  for (double n : {1.0, 2.0, 8.0, 32.0, 64.0, 1e3, 1e6}) {
    const DepthOfField t = textbookDepthOfField(kF, kS1, n, c);
    EXPECT_GT(t.nearLimit, 0.0);
    EXPECT_LE(t.nearLimit, kS1);
    if (kS1 >= t.hyperfocal) {
      EXPECT_TRUE(std::isinf(t.farLimit) && t.farLimit > 0) << "N = " << n;
      EXPECT_NEAR(t.nearLimit, kS1 * (t.hyperfocal - kF) / (t.hyperfocal + kS1 - 2 * kF), 1e-12);
    } else {
      EXPECT_GE(t.farLimit, kS1) << "N = " << n;
      EXPECT_TRUE(std::isfinite(t.farLimit));
    }
    const DepthOfField s = seedDepthOfField(kF, kS1, n, c);
    EXPECT_TRUE(std::isinf(s.farLimit) || s.farLimit >= kS1) << "seed DF must never be negative, N = " << n;
  }
  // Exactly at the hyperfocal distance.
  const double n = 16.0;
  const double h = kF * kF / (n * c) + kF;
  EXPECT_TRUE(std::isinf(textbookDepthOfField(kF, h, n, c).farLimit));
  EXPECT_NEAR(textbookDepthOfField(kF, h, n, c).nearLimit, h * (h - kF) / (2 * h - 2 * kF), 1e-9);
}

}  // namespace
}  // namespace lensfarm
