// Aspheric surfaces (camera/lens_system.h, the even asphere of ISO 10110-12) against geometry
// known in closed form: Newton's crossing lies on the sag it solves and on a paraboloid's
// z = c r^2 / 2, and a plano-convex lens whose convex face is a hyperboloid of eccentricity n
// (conic k = -n^2) focuses a parallel beam to a point (the Cartesian oval of refraction from glass
// into air: Hecht, Optics, 5th ed., §5.2.1; Born and Wolf, §4.2.3), where the same lens with a
// spherical face shows spherical aberration.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "common/camera/lens_system.h"
#include "common/util/error.h"

namespace lensfarm {
namespace {

constexpr double kIndex = 1.5, kRadius = 25.0;

// Stop, a flat front face, 6 mm of glass and the convex rear face (centre toward the object) of
// conic `k`: EFL R / (n - 1) = 50 mm.
LensSystem planoConvex(double k, std::vector<double> aspheric = {}, double stopDiameter = 24.0) {
  LensSurface stop{0.0, 1.0, 1.0, 0.0, stopDiameter, true};
  LensSurface front{0.0, 6.0, kIndex, 0.0, 30.0, false};
  LensSurface back{-kRadius, 0.0, 1.0, 0.0, 30.0, false};
  back.conic = k;
  back.aspheric = std::move(aspheric);
  return LensSystem({stop, front, back}, "plano-convex");
}

// RMS distance from the axis, on the plane z, of a parallel beam across the stop (rays at
// heights up to 0.98 of its radius, along one diameter and the other).
double axialSpread(const LensSystem& lens, double z, double stopRadius = 12.0) {
  double sum2 = 0.0;
  int n = 0;
  for (int i = -20; i <= 20; ++i)
    for (const DVec3 dir : {DVec3(1, 0, 0), DVec3(0, 1, 0)}) {
      const DVec3 start = (0.98 * stopRadius * i / 20.0) * dir + DVec3(0.0, 0.0, -5.0);
      const auto out = lens.traceFromObjectSide({start, DVec3(0.0, 0.0, 1.0)});
      EXPECT_TRUE(out) << i;
      if (!out) continue;
      const DVec3 p = out->origin + (z - out->origin.z) / out->direction.z * out->direction;
      sum2 += p.x * p.x + p.y * p.y, ++n;
    }
  return std::sqrt(sum2 / n);
}

TEST(Asphere, AHyperboloidOfEccentricityNFocusesAParallelBeamToAPoint) {
  const LensSystem hyper = planoConvex(-kIndex * kIndex), sphere = planoConvex(0.0);
  // Paraxially the two are one lens: the vertex curvature alone sets the first-order figures.
  EXPECT_NEAR(hyper.paraxial().efl, kRadius / (kIndex - 1.0), 1e-9);
  EXPECT_EQ(hyper.paraxial().bfl, sphere.paraxial().bfl);
  const double focus = hyper.totalTrack() + hyper.paraxial().bfl;
  // At f/2 the hyperboloid's rays meet at the focus to rounding; the sphere's spread by ~0.1 mm.
  EXPECT_LT(axialSpread(hyper, focus), 1e-9);
  EXPECT_GT(axialSpread(sphere, focus), 0.05);
  // And the exact focus finds the hyperboloid's at its paraxial one.
  const auto f = hyper.exactFocus(INFINITY);
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->exact, f->paraxial, 1e-9);
  EXPECT_LT(f->exactRms, 1e-9);
}

TEST(Asphere, NewtonsCrossingLiesOnTheSagAndTheNormalIsItsGradient) {
  // A paraboloid (k = -1: z = c r^2 / 2 exactly) with a strong A4 and A6 on top.
  const std::vector<double> a = {2e-6, -3e-9};
  const LensSystem lens = planoConvex(-1.0, a);
  const LensSurface& s = lens.surfaces()[2];
  const double c = -1.0 / kRadius;
  for (double r : {0.0, 3.0, 8.0, 14.0})
    EXPECT_NEAR(s.sag(r), c * r * r / 2.0 + a[0] * std::pow(r, 4) + a[1] * std::pow(r, 6), 1e-12) << r;
  // The slope is the sag's derivative (a central difference).
  for (double r : {1.0, 7.0, 13.0}) EXPECT_NEAR(s.sagSlope(r), (s.sag(r + 1e-5) - s.sag(r - 1e-5)) / 2e-5, 1e-8) << r;
  for (double y : {0.5, 5.0, 11.0}) {
    std::vector<DVec3> hits;
    // An oblique ray, so the crossing is not at the height it started at.
    const auto out = lens.traceFromObjectSide({DVec3(0.3, y, -5.0), glm::normalize(DVec3(0.02, -0.1, 1.0))},
                                              LensSystem::kWavelengthD, &hits);
    ASSERT_TRUE(out) << y;
    ASSERT_EQ(hits.size(), 3u);
    const DVec3 p = hits[2];
    EXPECT_NEAR(p.z - lens.vertexZ(2), s.sag(std::hypot(p.x, p.y)), 1e-10) << y;
    // Snell's law at the hit, with the normal from the sag's gradient: the tangential components of
    // n d are continuous (n sin i = n' sin t), whatever the normal's sign.
    const double r = std::hypot(p.x, p.y), slope = s.sagSlope(r);
    const DVec3 normal = glm::normalize(DVec3(-slope * p.x / r, -slope * p.y / r, 1.0));
    // Inside the glass the ray has only crossed the flat front face: its transverse components
    // are the incoming ones over n (Snell at a plane).
    const DVec3 d0 = glm::normalize(DVec3(0.02, -0.1, 1.0));
    const DVec3 t0(d0.x / kIndex, d0.y / kIndex, 0.0);
    const DVec3 inGlass(t0.x, t0.y, std::sqrt(1.0 - glm::dot(t0, t0)));
    const DVec3 tangentIn = kIndex * (inGlass - glm::dot(inGlass, normal) * normal);
    const DVec3 tangentOut = 1.0 * (out->direction - glm::dot(out->direction, normal) * normal);
    EXPECT_NEAR(glm::length(tangentIn - tangentOut), 0.0, 1e-12) << y;
  }
}

TEST(Asphere, ASphereWrittenAsAConicOfZeroIsTheSphere) {
  // k = 0 and zero coefficients take the sphere's closed-form path: the same bits.
  const LensSystem plain = planoConvex(0.0), zeros = planoConvex(0.0, {0.0, 0.0});
  EXPECT_TRUE(zeros.surfaces()[2].spherical());
  const auto a = plain.traceFromObjectSide({DVec3(0.1, 9.0, -5.0), DVec3(0.0, 0.0, 1.0)});
  const auto b = zeros.traceFromObjectSide({DVec3(0.1, 9.0, -5.0), DVec3(0.0, 0.0, 1.0)});
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->origin, b->origin);
  EXPECT_EQ(a->direction, b->direction);
}

TEST(Asphere, BadAsphericSurfacesAreRefusedNamingTheField) {
  const auto problem = [](double k, std::vector<double> a, double aperture) {
    LensSurface s{-kRadius, 0.0, 1.0, 0.0, aperture, false};
    s.conic = k;
    s.aspheric = std::move(a);
    const auto p = LensSystem::problemWith(s);
    return p ? p->field : std::string("none");
  };
  EXPECT_EQ(problem(-2.25, {}, 30.0), "none");
  // An oblate ellipsoid (k = 3) of R 25 closes at r = R / sqrt(1 + k) = 12.5 mm.
  EXPECT_EQ(problem(3.0, {}, 30.0), "aperture");
  EXPECT_EQ(problem(NAN, {}, 30.0), "conic");
  EXPECT_EQ(problem(0.0, {1, 1, 1, 1, 1, 1, 1, 1}, 30.0), "aspheric");
  EXPECT_EQ(problem(0.0, {INFINITY}, 30.0), "aspheric");
  // A ray that misses the closed conic is a miss, not a crash.
  LensSurface oblate{-kRadius, 0.0, 1.0, 0.0, 20.0, false};
  oblate.conic = 3.0;
  const LensSystem lens(
      {LensSurface{0.0, 1.0, 1.0, 0.0, 24.0, true}, LensSurface{0.0, 6.0, kIndex, 0.0, 30.0, false}, oblate}, "oblate");
  EXPECT_FALSE(lens.traceFromObjectSide({DVec3(0.0, 11.9, -5.0), DVec3(0.0, 0.0, 1.0)}));
}

}  // namespace
}  // namespace lensfarm
