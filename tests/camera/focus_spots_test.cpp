// The spots of points on the plane of focus (camera/focus_spots.h; docs/figure7.md, the report's
// Figure 7d question), against expectations computed here independently: the ideal thin lens
// images the focal plane without blur; the seed's eq. 1 with a unit n1 blurs the axial point by
// an amount integrated here in closed form over the aperture's radius; a real lens lies between
// and lights nothing past its image circle. And `lensfarm dof --spots`, the real binary.
#include "camera/focus_spots.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <regex>

#include "camera/depth_of_field.h"
#include "exit_codes.h"
#include "scene/scene_loader.h"
#include "test_support.h"

namespace lensfarm {
namespace {

ThinLensParams seedCameraAt(double fNumber) {
  ThinLensParams p = loadScene(test::scenesDir() / "cornell-seed.json").camera().params();
  p.fNumber = fNumber;
  return p;
}

double coc(const ThinLensParams& p) { return circleOfConfusion(p.sensorWidth, p.sensorHeight); }

TEST(FocusSpots, TheIdealThinLensImagesThePlaneOfFocusWithoutBlurAtEveryFieldAndAperture) {
  for (double n : {1.4, 4.0}) {
    const ThinLensParams p = seedCameraAt(n);
    for (const FocusSpot& s : thinLensFocusSpots(p, ThinLensRule::kIdealThinLens, 8))
      EXPECT_LT(s.rmsDiameter, 1e-3 * coc(p)) << "f/" << n << " field " << s.field;  // float rounding only
  }
}

// On the axis, eq. 1 with a unit n1 sends the ray through lens radius rho to the focal plane at
// radius rho (S1 / f) (L / S2 - 1), L = sqrt(S2^2 + rho^2) (from n2 = n1 - r/f, x = rho + S1 n2x /
// n2z and 1/S1 + 1/S2 = 1/f), so its RMS spot radius over the disk of radius R is
//     sqrt( (2 / R^2) Int_0^R rho^3 (S1/f)^2 (L/S2 - 1)^2 drho ),
// times S2 / S1 on the sensor. Integrated here by Simpson's rule.
double seedAxialRmsDiameter(const ThinLensParams& p) {
  const double f = p.focalLength, s1 = p.focusDistance, s2 = 1.0 / (1.0 / f - 1.0 / s1), big = f / (2.0 * p.fNumber);
  const int n = 2000;
  double sum = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double rho = big * k / n, l = std::sqrt(s2 * s2 + rho * rho);
    const double g = rho * rho * rho * (s1 / f) * (s1 / f) * (l / s2 - 1.0) * (l / s2 - 1.0);
    sum += g * (k == 0 || k == n ? 1.0 : k % 2 ? 4.0 : 2.0);
  }
  const double integral = sum * (big / n) / 3.0;
  return 2.0 * std::sqrt(2.0 / (big * big) * integral) * s2 / s1;
}

TEST(FocusSpots, TheSeedsEquationAsWrittenBlursTheAxisAsTheClosedFormSaysAndMoreOffIt) {
  const ThinLensParams p = seedCameraAt(1.4);
  const std::vector<FocusSpot> spots = thinLensFocusSpots(p, ThinLensRule::kSeedEquationAsWritten, 8, 96);
  EXPECT_NEAR(spots[0].rmsDiameter / seedAxialRmsDiameter(p), 1.0, 0.02);
  EXPECT_GT(spots[0].rmsDiameter, 10.0 * coc(p)) << "far from acceptably sharp even on the axis";
  for (size_t k = 1; k < spots.size(); ++k) EXPECT_GT(spots[k].rmsDiameter, spots[k - 1].rmsDiameter) << k;
  EXPECT_GT(spots.back().rmsDiameter, 5.0 * spots[0].rmsDiameter) << "the corner much blurrier than the centre";
  // Closing the aperture shrinks it: at f/16 the axial spot is the closed form's too, and below c.
  const ThinLensParams narrow = seedCameraAt(16.0);
  const double axial = thinLensFocusSpots(narrow, ThinLensRule::kSeedEquationAsWritten, 1, 96)[0].rmsDiameter;
  EXPECT_NEAR(axial / seedAxialRmsDiameter(narrow), 1.0, 0.02);
  EXPECT_LT(axial, coc(narrow));
}

TEST(FocusSpots, AFastRealLensBlursLessThanTheSeedsEquationAndLightsNothingPastItsImageCircle) {
  const Scene real = loadScene(test::scenesDir() / "cornell-seed-fast-lens.json");
  ASSERT_TRUE(real.realLens);
  const ThinLensParams seed = seedCameraAt(1.4);
  const std::vector<FocusSpot> lens = realLensFocusSpots(real.camera().params(), *real.realLens, 8);
  const std::vector<FocusSpot> eq1 = thinLensFocusSpots(seed, ThinLensRule::kSeedEquationAsWritten, 8);
  EXPECT_GT(lens[0].passing, 0.5);
  EXPECT_LT(lens[0].rmsDiameter, 2.0 * coc(seed)) << "near the axis the f/1.4 design is nearly sharp";
  for (size_t k = 0; k < lens.size(); ++k) {
    if (lens[k].passing > 0.0) {
      EXPECT_LT(lens[k].rmsDiameter, 0.25 * eq1[k].rmsDiameter) << k;
    }
  }
  // Its design covers 13 degrees half field (23 mm of image height at 100 mm): the seed's 37
  // degree half-diagonal is beyond it, and the corner gets no light.
  EXPECT_EQ(lens.back().passing, 0.0);
}

TEST(FocusSpots, TheDofCommandPrintsAndPlotsThem) {
  test::TempDir dir;
  const auto svg = dir / "spots.svg";
  const auto r = test::runProcess({test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(),
                                   "--f-numbers", "1.4", "--spots", "1.4", "--compare",
                                   (test::scenesDir() / "cornell-seed-fast-lens.json").string(), "--svg", svg.string()},
                                  120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // The axial row: field 0, the seed's eq. 1 about 22 c, the ideal lens 0, the real lens below 2 c.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(\n 0\.000 +0 +([0-9.]+) +([0-9.]+) +([0-9.]+) )"))) << r.out;
  EXPECT_NEAR(std::stod(m[1]), seedAxialRmsDiameter(seedCameraAt(1.4)) / coc(seedCameraAt(1.4)), 0.5);
  EXPECT_EQ(std::stod(m[2]), 0.0);
  EXPECT_LT(std::stod(m[3]), 2.0);
  EXPECT_NE(r.out.find("no light"), std::string::npos) << "the corner, past the real lens's image circle";
  const std::string plot = test::readFile(svg);
  EXPECT_EQ(plot.rfind("<svg", 0), 0u);
  EXPECT_NE(plot.find("</svg>"), std::string::npos);
  EXPECT_EQ(std::count(plot.begin(), plot.end(), '\n') > 10, true);
  // --compare needs a real lens; --svg needs --spots.
  const auto thin = test::runProcess({test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(),
                                      "--spots", "1.4", "--compare",
                                      (test::scenesDir() / "cornell-seed.json").string()},
                                     60);
  EXPECT_EQ(thin.exitCode, cli::kBadInput);
  EXPECT_NE(thin.err.find("--compare"), std::string::npos) << thin.err;
  const auto noSpots = test::runProcess(
      {test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(), "--svg", svg.string()}, 60);
  EXPECT_EQ(noSpots.exitCode, cli::kBadInput);
  EXPECT_NE(noSpots.err.find("--spots"), std::string::npos) << noSpots.err;
}

}  // namespace
}  // namespace lensfarm
