// A real lens from its prescription (camera/lens_system.h), checked against values computed
// independently: the thick-lens lensmaker's equation, a 2x2 ray-transfer-matrix product written
// here, Newton's imaging equation, and the exact trace's paraxial limit.
#include "common/camera/lens_system.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/util/error.h"
#include "tests/camera/paraxial_reference.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

// A biconvex singlet (R1 = 50, R2 = -50, 5 mm of n = 1.5) with the stop 2 mm behind it.
LensSystem singlet(double index = 1.5, double abbe = 0.0) {
  return LensSystem(
      {{50.0, 5.0, index, abbe, 20.0, false}, {-50.0, 2.0, 1.0, 0.0, 20.0, false}, {0.0, 0.0, 1.0, 0.0, 10.0, true}},
      "singlet");
}

LensSystem doubleGauss() {
  return LensSystem::parsePbrt(test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"), "dgauss.50mm.dat");
}

TEST(LensSystem, ASingletsFocalLengthIsTheThickLensmakersEquation) {
  const double n = 1.5, r1 = 50.0, r2 = -50.0, d = 5.0;
  const double f = 1.0 / ((n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * d / (n * r1 * r2)));  // Hecht eq. 6.2
  const LensSystem::Paraxial p = singlet().paraxial();
  EXPECT_NEAR(p.efl, f, 1e-9 * f);
  // Back focal length from the lens's rear vertex: f (1 - (n - 1) d / (n r1)) (Hecht eq. 6.3);
  // LensSystem measures it from the last surface, the stop 2 mm behind.
  EXPECT_NEAR(p.bfl + 2.0, f * (1.0 - (n - 1.0) * d / (n * r1)), 1e-9 * f);
  EXPECT_NEAR(p.ffl, f * (1.0 + (n - 1.0) * d / (n * r2)), 1e-9 * f);
  // Petzval sum of a thin-ish singlet: (n - 1)/n (1/r1 - 1/r2).
  EXPECT_NEAR(p.petzvalSum, (n - 1.0) / n * (1.0 / r1 - 1.0 / r2), 1e-12);
  // The stop is behind the lens: the exit pupil is the stop itself; the entrance pupil is its
  // image through the lens. Gaussian imaging between the principal planes: the stop is s behind
  // the rear one; its image lies s' = 1 / (1/f - 1/s) from the front one (virtual: negative,
  // behind it), magnified s' / s.
  EXPECT_DOUBLE_EQ(p.exitPupilDiameter, 10.0);
  const double s = 7.0 - p.rearPrincipalZ, sImage = 1.0 / (1.0 / f - 1.0 / s);
  EXPECT_NEAR(p.entrancePupilZ, p.frontPrincipalZ - sImage, 1e-9);
  EXPECT_NEAR(p.entrancePupilDiameter, 10.0 * std::abs(sImage / s), 1e-9);
  EXPECT_NEAR(p.fNumber, p.efl / p.entrancePupilDiameter, 1e-12);
}

TEST(LensSystem, TheDoubleGaussMatchesAnIndependentRayTransferMatrix) {
  const LensSystem lens = doubleGauss();
  const test::Abcd m = test::systemMatrix(lens.surfaces());
  const LensSystem::Paraxial p = lens.paraxial();
  EXPECT_NEAR(p.efl, m.efl(), 1e-9);
  EXPECT_NEAR(p.bfl, m.bfl(), 1e-9);
  EXPECT_NEAR(p.ffl, m.ffl(), 1e-9);
  EXPECT_NEAR(p.efl, 50.0, 0.01 * 50.0) << "a 50 mm lens (scaled from the patent's 100 mm)";
  EXPECT_NEAR(p.fNumber, 2.0, 0.05) << "an f/2 design";
  EXPECT_EQ(lens.stopIndex(), 5u);
}

TEST(LensSystem, FocusFollowsNewtonsEquation) {
  // x x' = -f f' in air: an object x in front of the front focal point images x' = f^2 / x behind
  // the rear focal point (Hecht eq. 5.13).
  for (const LensSystem& lens : {singlet(), doubleGauss()}) {
    const LensSystem::Paraxial p = lens.paraxial();
    for (double distance : {200.0, 1000.0, 5000.0}) {
      const double x = distance - p.ffl;
      const std::optional<double> image = lens.focusDistanceFromRear(distance);
      ASSERT_TRUE(image);
      EXPECT_NEAR(*image, p.bfl + p.efl * p.efl / x, 1e-9 * *image) << distance;
    }
    EXPECT_EQ(lens.focusDistanceFromRear(INFINITY), p.bfl);
    EXPECT_FALSE(lens.focusDistanceFromRear(0.5 * p.ffl)) << "inside the front focal length: a virtual image";
  }
}

TEST(LensSystem, ExactRaysNearTheAxisMeetAtTheParaxialFocus) {
  for (const LensSystem& lens : {singlet(), doubleGauss()}) {
    const LensSystem::Paraxial p = lens.paraxial();
    const double height = 1e-3;
    const auto out = lens.traceFromObjectSide({DVec3(0.0, height, -10.0), DVec3(0.0, 0.0, 1.0)});
    ASSERT_TRUE(out);
    const double crossing = out->origin.z - out->origin.y / out->direction.y * out->direction.z;
    EXPECT_NEAR(crossing - lens.totalTrack(), p.bfl, 1e-5 * p.bfl);
    // Reversible: the ray traced back from the image side returns to where it came from.
    const auto back = lens.traceFromImageSide({out->origin + out->direction, -out->direction});
    ASSERT_TRUE(back);
    EXPECT_NEAR(back->origin.y, height, 1e-9);
    EXPECT_NEAR(back->direction.z, -1.0, 1e-12);
  }
}

TEST(LensSystem, ClearAperturesVignetteAndTheStopLimitsTheBeam) {
  const LensSystem lens = singlet();
  // A ray outside the front surface's 20 mm clear aperture is stopped.
  EXPECT_FALSE(lens.traceFromObjectSide({DVec3(0.0, 10.5, -10.0), DVec3(0.0, 0.0, 1.0)}));
  // One inside it that the lens bends outside the 10 mm stop is stopped too.
  EXPECT_FALSE(lens.traceFromObjectSide({DVec3(0.0, 9.0, -10.0), DVec3(0.0, 0.0, 1.0)}));
  EXPECT_TRUE(lens.traceFromObjectSide({DVec3(0.0, 4.0, -10.0), DVec3(0.0, 0.0, 1.0)}));
}

TEST(LensSystem, TheAbbeNumberSetsTheDispersion) {
  const LensSystem lens = singlet(1.5168, 64.17);  // N-BK7
  EXPECT_TRUE(lens.disperses());
  EXPECT_FALSE(singlet().disperses());
  const double nF = lens.indexAfter(0, LensSystem::kWavelengthF), nC = lens.indexAfter(0, LensSystem::kWavelengthC);
  EXPECT_NEAR(nF - nC, (1.5168 - 1.0) / 64.17, 1e-12);
  EXPECT_DOUBLE_EQ(lens.indexAfter(0, LensSystem::kWavelengthD), 1.5168);
  // N-BK7's catalogue indices at F and C (Schott): 1.52238 and 1.51432, within Cauchy's fit.
  EXPECT_NEAR(nF, 1.52238, 5e-4);
  EXPECT_NEAR(nC, 1.51432, 5e-4);
  // Blue focuses nearer the lens than red (longitudinal chromatic aberration).
  EXPECT_LT(lens.paraxial(LensSystem::kWavelengthF).efl, lens.paraxial(LensSystem::kWavelengthC).efl);
}

TEST(LensSystem, BadPrescriptionsAreRefusedNamingTheLineOrSurface) {
  const auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([] { LensSystem::parsePbrt("# a lens\n50 5 1.5 20\n-50 x 1 20\n", "bad.dat"); }).find("bad.dat:3"),
            std::string::npos);
  EXPECT_NE(message([] { LensSystem::parsePbrt("50 5 1.5\n", "short.dat"); }).find("short.dat:1"), std::string::npos);
  EXPECT_NE(message([] {
              LensSystem::parsePbrt("50 5 1.5 20\n-50 2 1 20\n", "nostop.dat");
            }).find("exactly one aperture stop"),
            std::string::npos);
  EXPECT_NE(message([] { LensSystem::parsePbrt("5 1 1.5 20\n0 1 0 5\n", "tight.dat"); }).find("surface 1"),
            std::string::npos)
      << "an aperture wider than its sphere";
  EXPECT_NE(message([] { LensSystem::parsePbrt("50 -1 1.5 20\n0 1 0 5\n", "neg.dat"); }).find("thickness"),
            std::string::npos);
  EXPECT_NE(message([] { LensSystem::parsePbrt("50 1 1.5 20\n0 1 0 5\n", "glass.dat"); }).find("end in air"),
            std::string::npos);
  EXPECT_NE(message([] { LensSystem::parsePbrt("", "empty.dat"); }).find("at least one surface"), std::string::npos);
}

}  // namespace
}  // namespace lensfarm
