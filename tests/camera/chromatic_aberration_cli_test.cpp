// Lateral colour on the command line: `lensfarm lens` prints a lens's lateral colour as
// lateralColour (camera/lens_analysis.h) computes it. Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <string>

#include "common/camera/lens_analysis.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

// `lensfarm lens` prints the double-Gauss's lateral colour as lateralColour computes it.
TEST(ChromaticAberration, TheLensCommandPrintsTheLateralColour) {
  const auto file = test::scenesDir() / "lenses/dgauss.50mm.dat";
  const auto r = test::runProcess({test::cliPath().string(), "lens", file.string()}, 60);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      r.out, m, std::regex(R"(lateral colour at ([0-9.]+)°: .* red - blue (-?[0-9.]+) um\n(?!lateral))")))
      << r.out;
  const LensSystem lens = LensSystem::parsePbrt(test::readFile(file), "dgauss.50mm.dat");
  const double half = std::atan(std::hypot(36.0, 24.0) / 2.0 / lens.paraxial().efl) * 180.0 / M_PI;
  EXPECT_NEAR(std::stod(m[1]), half, 0.01);
  const LateralColour lc = lateralColour(lens, half, INFINITY, lens.totalTrack() + lens.paraxial().bfl);
  EXPECT_NEAR(std::stod(m[2]), 1000.0 * lc.lateral, 0.01);
  EXPECT_GT(lc.lateral, 0.005) << "the double-Gauss's glasses disperse: red images farther out than blue";
}

}  // namespace
}  // namespace lensfarm
