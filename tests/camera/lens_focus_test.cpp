// Focusing by moving the lens group (LensSystem::exactFocus): the thick-lens (paraxial) film
// distance refined to the least RMS spot of the axial point. Checked against a brute-force scan
// of film positions traced here, against third-order aberration theory (with spherical
// aberration W040 rho^4 the least-RMS spot lies 2/3 of the way from the paraxial to the marginal
// focus: minimise the integral of (4 W040 rho^3 + 2 W020 rho)^2 rho over the pupil, W020 =
// -4/3 W040, against -2 W040 at the marginal focus; Welford, Aberrations of Optical Systems,
// §9.2), and for a near-paraxial singlet, where it must agree with the paraxial focus.
#include <gtest/gtest.h>

#include <cmath>

#include "common/camera/lens_system.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

// A biconvex N-BK7 singlet (R 50 / -50, 5 mm) with the stop `stop` mm wide 2 mm in front.
LensSystem singlet(double stop) {
  return LensSystem(
      {{0.0, 2.0, 1.0, 0.0, stop, true}, {50.0, 5.0, 1.5168, 0.0, 40.0, false}, {-50.0, 0.0, 1.0, 0.0, 40.0, false}},
      "singlet");
}

// Where a ray entering parallel at height h (or from the axial point at `distance`) crosses
// the axis behind the last vertex.
double axisCrossing(const LensSystem& lens, double h, double distance) {
  const DVec3 origin = std::isinf(distance) ? DVec3(0.0, h, -1.0) : DVec3(0.0, 0.0, -distance);
  const DVec3 dir = std::isinf(distance) ? DVec3(0.0, 0.0, 1.0) : glm::normalize(DVec3(0.0, h, distance));
  const auto out = lens.traceFromObjectSide({origin, dir});
  EXPECT_TRUE(out) << h;
  return out->origin.z - out->origin.y / out->direction.y * out->direction.z - lens.totalTrack();
}

// The on-axis spot's RMS radius on the film `back` mm behind the last vertex, by tracing a polar
// grid of the stop (a different sampling from exactFocus's square one), area-weighted.
double rmsSpot(const LensSystem& lens, double back, double distance) {
  const double radius = lens.surfaces()[lens.stopIndex()].aperture / 2;
  double sum = 0.0, weight = 0.0;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 48; ++j) {
      const double r = radius * (i + 0.5) / 60 * 0.999, phi = 2.0 * M_PI * j / 48;
      const DVec3 atStop(r * std::cos(phi), r * std::sin(phi), 0.0);
      const DVec3 origin = std::isinf(distance) ? atStop - DVec3(0, 0, 1) : DVec3(0.0, 0.0, -distance);
      const auto out = lens.traceFromObjectSide({origin, glm::normalize(atStop - origin)});
      if (!out) continue;
      const double z = lens.totalTrack() + back;
      const DVec3 p = out->origin + (z - out->origin.z) / out->direction.z * out->direction;
      sum += r * (p.x * p.x + p.y * p.y), weight += r;
    }
  return std::sqrt(sum / weight);
}

TEST(ExactFocus, IsTheLeastSpotOfABruteForceScanAndBeatsTheParaxialFocus) {
  const LensSystem fast = singlet(20.0);  // f/2.5: strong spherical aberration
  for (const double distance : {double(INFINITY), 1000.0}) {
    const auto f = fast.exactFocus(distance);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->paraxial, *fast.focusDistanceFromRear(distance));
    // An undercorrected singlet's best focus is nearer the lens than its paraxial one.
    EXPECT_LT(f->exact, f->paraxial - 0.1);
    EXPECT_LT(f->exactRms, 0.5 * f->paraxialRms) << distance;
    // A scan of film positions traced independently finds its least spot at the same place.
    double best = 0.0, bestRms = 1e30;
    for (int k = -400; k <= 100; ++k) {
      const double back = f->paraxial + 0.01 * k;
      const double rms = rmsSpot(fast, back, distance);
      if (rms < bestRms) bestRms = rms, best = back;
    }
    EXPECT_NEAR(f->exact, best, 0.02) << distance;
    EXPECT_NEAR(f->exactRms, bestRms, 0.03 * bestRms) << distance;
  }
}

TEST(ExactFocus, SitsTwoThirdsOfTheWayToTheMarginalFocusInThirdOrder) {
  const LensSystem slow = singlet(6.0);  // f/8: third-order spherical aberration dominates
  const auto f = slow.exactFocus(INFINITY);
  ASSERT_TRUE(f);
  const double marginal = axisCrossing(slow, 3.0 * 0.9999, INFINITY);
  EXPECT_NEAR(f->exact - f->paraxial, 2.0 / 3.0 * (marginal - f->paraxial), 0.03 * std::abs(marginal - f->paraxial));
}

TEST(ExactFocus, AgreesWithTheParaxialFocusForANearParaxialSinglet) {
  const LensSystem pinhole = singlet(1.0);  // f/50
  for (const double distance : {double(INFINITY), 500.0}) {
    const auto f = pinhole.exactFocus(distance);
    ASSERT_TRUE(f);
    EXPECT_NEAR(f->exact, f->paraxial, 1e-3 * f->paraxial) << distance;
  }
  EXPECT_FALSE(pinhole.exactFocus(10.0)) << "inside the front focal length: no real image";
}

TEST(ExactFocus, TheDoubleGaussIsSharperAtItsExactFocus) {
  const LensSystem lens =
      LensSystem::parsePbrt(test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"), "dgauss.50mm.dat");
  const auto f = lens.exactFocus(2900.0);
  ASSERT_TRUE(f);
  EXPECT_LE(f->exactRms, f->paraxialRms);
  EXPECT_NEAR(f->exact, f->paraxial, 1.0) << "a well-corrected lens: within a millimetre";
}

}  // namespace
}  // namespace lensfarm
