// `lensfarm dof --spots` (camera/focus_spots.h; docs/figure7.md): the table of spots on the plane
// of focus and its SVG plot, against the 2013 report's eq. 1 integrated here in closed form, and the
// refusals of --compare without a real lens and --svg without --spots. Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <algorithm>
#include <regex>
#include <string>

#include "client/exit_codes.h"
#include "tests/camera/focus_spots_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::coc;
using test::seedAxialRmsDiameter;
using test::seedCameraAt;

TEST(FocusSpots, TheDofCommandPrintsAndPlotsThem) {
  test::TempDir dir;
  const auto svg = dir / "spots.svg";
  const auto r = test::runProcess({test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(),
                                   "--f-numbers", "1.4", "--spots", "1.4", "--compare",
                                   (test::scenesDir() / "cornell-seed-fast-lens.json").string(), "--svg", svg.string()},
                                  120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // The axial row: field 0, the report's eq. 1 about 22 c, the ideal lens 0, the real lens below 2 c.
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
  const auto thin =
      test::runProcess({test::cliPath().string(), "dof", (test::scenesDir() / "cornell-seed.json").string(), "--spots",
                        "1.4", "--compare", (test::scenesDir() / "cornell-seed.json").string()},
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
