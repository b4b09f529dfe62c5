// `lensfarm lens FILE` (client/lens_command.cpp), the real binary: its first-order figures match
// an independent ray-transfer-matrix computation, its field table starts on the axis, its SVG is
// written whole, and a bad lens file is refused naming the line.
#include <gtest/gtest.h>

#include <regex>

#include "client/exit_codes.h"
#include "tests/camera/paraxial_reference.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

double figure(const std::string& out, const std::string& label) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex(label + R"( +(-?[0-9.]+))"))) return NAN;
  return std::stod(m[1]);
}

TEST(LensCommand, ReportsTheDoubleGaussAsAnIndependentMatrixComputationDoes) {
  const auto lensFile = test::scenesDir() / "lenses/dgauss.50mm.dat";
  test::TempDir dir;
  const auto r =
      test::runProcess({test::cliPath().string(), "lens", lensFile.string(), "--svg", (dir / "x.svg").string()}, 60);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const test::Abcd m =
      test::systemMatrix(LensSystem::parsePbrt(test::readFile(lensFile), lensFile.string()).surfaces());
  EXPECT_NEAR(figure(r.out, "effective focal length"), m.efl(), 1e-4) << r.out;
  EXPECT_NEAR(figure(r.out, "back focal length"), m.bfl(), 1e-4) << r.out;
  EXPECT_NEAR(figure(r.out, "front focal length"), m.ffl(), 1e-4) << r.out;
  // Field of view on the default 36 x 24 mm sensor: 2 atan(18 / f).
  std::smatch fov;
  ASSERT_TRUE(std::regex_search(r.out, fov, std::regex(R"(([0-9.]+) x ([0-9.]+) degrees)"))) << r.out;
  EXPECT_NEAR(std::stod(fov[1]), 2.0 * std::atan(18.0 / m.efl()) * 180.0 / M_PI, 0.01);
  // The field table starts on the axis: no distortion, everything through.
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(0\.00° +0\.0000 +0\.0000 +0\.000% +100\.0%)"))) << r.out;
  // The drawing: a whole SVG document, one path per surface.
  const std::string svg = test::readFile(dir / "x.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  size_t paths = 0;
  for (size_t at = svg.find("<path d=\""); at != std::string::npos; at = svg.find("<path d=\"", at + 1)) {
    ++paths;
    EXPECT_NE(svg.find("\"/>", at), std::string::npos);
    EXPECT_LT(svg.find("\"/>", at), svg.find('\n', at)) << "each element whole on its line";
  }
  EXPECT_EQ(paths, 11u);
}

TEST(LensCommand, RefusesABadLensFileNamingTheLine) {
  test::TempDir dir;
  const auto bad = dir.write("bad.dat", "# a lens\n50 5 1.5 20\n0 2 0 oops\n");
  const auto r = test::runProcess({test::cliPath().string(), "lens", bad.string()}, 60);
  EXPECT_EQ(r.exitCode, cli::kBadInput) << r.err;
  EXPECT_NE(r.err.find("bad.dat:3"), std::string::npos) << r.err;
  const auto missing = test::runProcess({test::cliPath().string(), "lens", (dir / "none.dat").string()}, 60);
  EXPECT_EQ(missing.exitCode, cli::kBadInput) << missing.err;
}

TEST(LensCommand, PrintsBothFocusesAndWritesThePlots) {
  const auto lensFile = test::scenesDir() / "lenses/dgauss.50mm.dat";
  test::TempDir dir;
  const auto r = test::runProcess(
      {test::cliPath().string(), "lens", lensFile.string(), "--focus", "2900", "--plots", (dir / "plots").string()},
      120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const LensSystem lens = LensSystem::parsePbrt(test::readFile(lensFile), lensFile.string());
  const auto focus = lens.exactFocus(2900.0);
  ASSERT_TRUE(focus);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(film ([0-9.]+) behind the last vertex paraxially)"))) << r.out;
  EXPECT_NEAR(std::stod(m[1]), focus->paraxial, 1e-4);
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(rays\) ([0-9.]+): RMS spot)"))) << r.out;
  EXPECT_NEAR(std::stod(m[1]), focus->exact, 1e-4);
  // The relative-illumination column: 100 % on the axis, and it falls off.
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(0\.00° +0\.0000 +0\.0000 +0\.000% +100\.0% +100\.0%)"))) << r.out;
  for (const char* name : {"cross-section.svg", "distortion.svg", "illumination.svg", "spots.svg"}) {
    const std::string svg = test::readFile(dir / "plots" / name);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u) << name;
    EXPECT_NE(svg.find("</svg>\n"), std::string::npos) << name;
  }
  // Four spot panels, each with its Airy circle.
  const std::string spots = test::readFile(dir / "plots/spots.svg");
  size_t airy = 0;
  for (size_t at = spots.find("stroke=\"#c00\""); at != std::string::npos; at = spots.find("stroke=\"#c00\"", at + 1))
    ++airy;
  EXPECT_EQ(airy, 4u);
}

TEST(LensCommand, ReadsAJsonPrescription) {
  test::TempDir dir;
  // A plano-convex singlet, f = 25 / 0.5 = 50 mm, its rear face a hyperboloid (constructed).
  const auto file = dir.write("singlet.json", R"({"name": "hyperbolic singlet", "surfaces": [
      {"stop": true, "radius": 0, "thickness": 1, "aperture": 10},
      {"radius": 0, "thickness": 6, "index": 1.5, "aperture": 30},
      {"radius": -25, "thickness": 0, "index": 1, "aperture": 30, "conic": -2.25}]})");
  const auto r = test::runProcess({test::cliPath().string(), "lens", file.string()}, 60);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NEAR(figure(r.out, "effective focal length"), 50.0, 1e-4) << r.out;
  EXPECT_NE(r.out.find("aspheric surfaces: 1"), std::string::npos) << r.out;
  const auto bad = dir.write("bad.json", R"({"surfaces": [{"radius": "x", "thickness": 1, "aperture": 10}]})");
  const auto b = test::runProcess({test::cliPath().string(), "lens", bad.string()}, 60);
  EXPECT_EQ(b.exitCode, cli::kBadInput) << b.err;
  EXPECT_NE(b.err.find("surfaces[0].radius"), std::string::npos) << b.err;
}

}  // namespace
}  // namespace lensfarm
