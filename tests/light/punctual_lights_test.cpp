// Point, spot and directional lights against their analytic irradiance on a white diffuse plane
// (albedo 1, so the radiance leaving it is E / pi), with every estimator: one path at a time
// through the centres of the sensor cells (light sampling makes these exact up to rounding), and
// whole renders through the unit renderer.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/light/light_test_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;
constexpr double kPi = std::numbers::pi;

double radians(double degrees) { return degrees * kPi / 180.0; }

// The radiance of the white plane at p lit by a point light of intensity I at `light`:
// (albedo / pi) I cos(theta) / r^2, scaled by `falloff`.
double pointLit(const DVec3& p, const DVec3& light, double intensity, double falloff = 1.0) {
  const DVec3 d = light - p;
  const double r2 = glm::dot(d, d), cosTheta = d.y / std::sqrt(r2);
  return intensity * falloff * cosTheta / r2 / kPi;
}

// Exact up to float rounding: the hit point is interpolated on a quad 200 across (about 1e-5 off)
// and the light sample computed in float.
constexpr double kRounding = 1e-4;

// Every sensor cell's centre ray (a different sample in each), compared with `expected` (per
// channel, the same value) within kRounding of `scale` (by default the value itself).
template <typename Expected, typename Scale>
void expectEveryCellCentre(const RenderScene& rs, Expected expected, Scale scale) {
  for (int j = 0; j < rs.camera().height(); ++j)
    for (int i = 0; i < rs.camera().width(); ++i) {
      CameraRay ray;
      const Spectrum l = test::traceCellCentre(rs, i, j, uint64_t(i + j), &ray);
      const DVec3 p = test::onPlaneY0(rs, ray);
      const double want = expected(p);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(l[c], want, kRounding * scale(p) + 1e-12) << "cell " << i << ", " << j;
    }
}
template <typename Expected>
void expectEveryCellCentre(const RenderScene& rs, Expected expected) {
  expectEveryCellCentre(rs, expected, expected);
}

// The mean of `expected` over a cell's footprint on the plane (a 16 x 16 grid of sensor points).
template <typename Expected>
double cellAverage(const RenderScene& rs, int i, int j, Expected expected) {
  double sum = 0.0;
  for (int a = 0; a < 16; ++a)
    for (int b = 0; b < 16; ++b)
      sum += expected(
          test::onPlaneY0(rs, rs.camera().paraxial().generateRay(
                                  i, j, Vec2((float(a) + 0.5f) / 16.0f, (float(b) + 0.5f) / 16.0f), Vec2(0.5f))));
  return sum / 256.0;
}

TEST(PointLight, IrradianceOnADiffusePlaneIsIntensityTimesCosineOverDistanceSquared) {
  const DVec3 light(0.5, 2.0, 0.3);
  const double intensity = 10.0;
  const auto expected = [&](const DVec3& p) { return pointLit(p, light, intensity); };
  for (const char* integrator : {"nee_mis", "nee", "naive"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    const Scene scene = test::loadSceneJson(
        dir,
        test::planeSceneJson({{{"type", "point"}, {"position", {0.5, 2, 0.3}}, {"intensity", intensity}}}, integrator));
    const RenderScene rs(scene);
    // One path per cell centre: exact up to float rounding.
    expectEveryCellCentre(rs, expected);
    // Whole renders: each cell's mean is the mean of the analytic radiance over its footprint
    // (16 samples, so within 1 %), and so is the image's (0.1 %).
    const std::vector<DVec3> means = test::cellMeans(rs);
    double mean = 0.0, wantMean = 0.0;
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 24; ++i) {
        const double want = cellAverage(rs, i, j, expected), got = means[size_t(j * 24 + i)].g;
        ASSERT_NEAR(got, want, 0.01 * want) << "cell " << i << ", " << j;
        mean += got, wantMean += want;
      }
    EXPECT_NEAR(mean, wantMean, 1e-3 * wantMean);
  }
}

TEST(SpotLight, IsThePointLightInsideItsConeBlackOutsideAndFollowsTheSmoothstepBetween) {
  // A spot 2 above the plane pointing straight down: the angle from its axis is the angle of
  // incidence. Full intensity within 20 degrees, nothing beyond 30, pbrt-v4's smoothstep between.
  const DVec3 light(0.0, 2.0, 0.0);
  const double intensity = 7.0, cosTotal = std::cos(radians(30)), cosStart = std::cos(radians(20));
  int inside = 0, between = 0, outside = 0;
  const auto expected = [&](const DVec3& p) {
    const DVec3 d = light - p;
    const double cosAxis = d.y / glm::length(d);
    const double t = std::clamp((cosAxis - cosTotal) / (cosStart - cosTotal), 0.0, 1.0);
    return pointLit(p, light, intensity, t * t * (3.0 - 2.0 * t));
  };
  const auto classify = [&](const DVec3& p) {
    const DVec3 d = light - p;
    const double cosAxis = d.y / glm::length(d);
    (cosAxis >= cosStart ? inside : cosAxis > cosTotal ? between : outside)++;
    return expected(p);
  };
  for (const char* integrator : {"nee_mis", "naive"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    const json spot = {{"type", "spot"},         {"position", {0, 2, 0}}, {"look_at", {0, -5, 0}},
                       {"intensity", intensity}, {"cone_angle", 30},      {"falloff_start", 20}};
    const Scene scene = test::loadSceneJson(dir, test::planeSceneJson(json::array({spot}), integrator));
    const RenderScene rs(scene);
    // Near the cone's edge the smoothstep of float cosines is off by more than its own size: the
    // tolerance is that of the point light's value.
    expectEveryCellCentre(rs, classify, [&](const DVec3& p) { return pointLit(p, light, intensity); });
    // Inside the cone, the spot is exactly the point light.
    test::TempDir pointDir;
    const Scene pointScene = test::loadSceneJson(
        pointDir,
        test::planeSceneJson({{{"type", "point"}, {"position", {0, 2, 0}}, {"intensity", intensity}}}, integrator));
    const RenderScene point(pointScene);
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 24; ++i) {
        CameraRay ray;
        (void)test::traceCellCentre(rs, i, j, 0, &ray);
        const DVec3 d = light - test::onPlaneY0(rs, ray);
        if (d.y / glm::length(d) >= cosStart + 1e-6) {
          ASSERT_EQ(test::traceCellCentre(rs, i, j, 0).g, test::traceCellCentre(point, i, j, 0).g);
        }
      }
  }
  EXPECT_GT(inside, 20);
  EXPECT_GT(between, 20);
  EXPECT_GT(outside, 20);
}

TEST(DirectionalLight, APlaneLitAtAnAngleShowsAlbedoOverPiTimesIrradianceTimesCosine) {
  // E = 3 from 50 degrees off the normal: every point of the plane leaves E cos(50) / pi.
  const double e = 3.0, theta = radians(50);
  const double want = e * std::cos(theta) / kPi;
  const json toLight = {std::sin(theta), std::cos(theta), 0.0};
  for (const char* integrator : {"nee_mis", "nee", "naive"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    const Scene scene = test::loadSceneJson(
        dir, test::planeSceneJson({{{"type", "directional"}, {"direction", toLight}, {"irradiance", e}}}, integrator));
    const RenderScene rs(scene);
    expectEveryCellCentre(rs, [&](const DVec3&) { return want; });
    for (const DVec3& m : test::cellMeans(rs)) ASSERT_NEAR(m.r, want, kRounding * want);
  }
  // A sun 10 degrees across (a uniform disk of radiance E / (pi sin^2 5deg)) gives a surface the
  // same irradiance E cos(theta), the integral of L cos over the disk: within noise in every cell.
  for (const char* integrator : {"nee_mis", "nee"}) {
    SCOPED_TRACE(integrator);
    test::TempDir dir;
    json scene = test::planeSceneJson(
        {{{"type", "directional"}, {"direction", toLight}, {"irradiance", e}, {"angular_diameter", 10}}}, integrator);
    scene["render"]["samples_per_pixel"] = 64;
    const Scene loaded = test::loadSceneJson(dir, scene);
    const RenderScene rs(loaded);
    double mean = 0.0;
    for (const DVec3& m : test::cellMeans(rs)) {
      ASSERT_NEAR(m.r, want, 0.02 * want);
      mean += m.r / (24.0 * 24.0);
    }
    EXPECT_NEAR(mean, want, 2e-3 * want);
  }
}

// The fraction of the irradiance each cell of a row gets across the edge of a shadow: a sun
// straight above, a blocker (hidden from the camera) at height 1 over x < 0.
std::vector<double> shadowProfile(double angularDiameter) {
  json scene = test::planeSceneJson(
      {{{"type", "directional"}, {"direction", {0, 1, 0}}, {"irradiance", 1}, {"angular_diameter", angularDiameter}}});
  scene["camera"] = {
      {"type", "pinhole"}, {"position", {0, 4, 0}}, {"look_at", {0, 0, 0}}, {"up", {0, 0, 1}}, {"angle_of_view", 15}};
  scene["render"]["resolution"] = {64, 2};
  scene["render"]["samples_per_pixel"] = 64;
  scene["shapes"].push_back({{"type", "quad"},
                             {"corner", {-10, 1, -10}},
                             {"edge1", {10, 0, 0}},
                             {"edge2", {0, 0, 20}},
                             {"material", "white"},
                             {"visible_to_camera", false}});
  test::TempDir dir;
  const Scene loaded = test::loadSceneJson(dir, scene);
  const RenderScene rs(loaded);
  const std::vector<DVec3> means = test::cellMeans(rs);
  std::vector<double> row;
  for (int i = 0; i < 64; ++i) row.push_back(means[size_t(i)].r * kPi);
  return row;
}

TEST(DirectionalLight, ASunWithAnAngularDiameterCastsAPenumbra) {
  // The edge of the blocker at x = 0, 1 above the plane: a 10-degree sun's penumbra is
  // 2 tan(5 deg) = 0.17 wide, about 10 cells of this row; a delta sun's edge falls in one cell.
  const auto partial = [](const std::vector<double>& row) {
    int n = 0;
    for (double v : row) n += v > 0.03 && v < 0.97;
    return n;
  };
  const std::vector<double> hard = shadowProfile(0), soft = shadowProfile(10);
  EXPECT_LE(partial(hard), 1);
  EXPECT_GE(partial(soft), 6);
  EXPECT_NEAR(soft.front(), 0.0, 1e-6);
  EXPECT_NEAR(soft.back(), 1.0, 0.02);
}

TEST(DirectionalLight, ShadowRaysToTheSunEndBeyondALargeSceneFarFromTheCamera) {
  // A plane 9e9 from the camera, 8e9 across, and a blocker (hidden from the camera) halfway, over
  // x < 0: shadow rays to the sun run 3 r (r about 7e9, the sphere about the scene and the
  // camera) along unit directions; every cell is lit exactly or shadowed exactly, and nothing is
  // dropped. (Far larger triangles overflow Embree's own test: docs/numerics.md.)
  const double e = 2.0, s = 1e9;
  const DVec3 toLight = glm::normalize(DVec3(0.3, 0.2, -1.0));
  const double want = e * -toLight.z / kPi;
  json scene = test::planeSceneJson({{{"type", "directional"}, {"direction", {0.3, 0.2, -1}}, {"irradiance", e}}});
  scene["camera"] = {{"type", "pinhole"}, {"position", {0, 0, 0}}, {"look_at", {0, 0, 1}}, {"angle_of_view", 40}};
  scene["shapes"] = json::array({{{"type", "quad"},
                                  {"material", "white"},
                                  {"corner", {-4 * s, -4 * s, 9 * s}},
                                  {"edge1", {8 * s, 0, 0}},
                                  {"edge2", {0, 8 * s, 0}}},
                                 {{"type", "quad"},
                                  {"material", "white"},
                                  {"corner", {-5 * s, -5 * s, 5 * s}},
                                  {"edge1", {5 * s, 0, 0}},
                                  {"edge2", {0, 10 * s, 0}},
                                  {"visible_to_camera", false}}});
  test::TempDir dir;
  const Scene loaded = test::loadSceneJson(dir, scene);
  const RenderScene rs(loaded);
  int lit = 0, dark = 0;
  for (const DVec3& m : test::cellMeans(rs)) {
    ASSERT_TRUE(std::isfinite(m.r));
    if (m.r == 0.0) {
      ++dark;
    } else if (std::abs(m.r - want) <= kRounding * want) {
      ++lit;
    }
  }
  EXPECT_GT(lit, 100);
  EXPECT_GT(dark, 100);
  EXPECT_GE(lit + dark, 24 * 24 - 24) << "only the cells on the shadow's edge are partly lit";

  // So do shadow rays to a point light there.
  scene["lights"] = json::array({{{"type", "point"}, {"position", {2 * s, 1 * s, -4 * s}}, {"intensity", 1e20}}});
  const Scene withPoint = test::loadSceneJson(dir, scene, "point.json");
  const RenderScene point(withPoint);
  int shadowed = 0, bright = 0;
  for (const DVec3& m : test::cellMeans(point)) {
    ASSERT_TRUE(std::isfinite(m.r));
    shadowed += m.r == 0.0;
    bright += m.r > 0.0;
  }
  EXPECT_GT(shadowed, 100);
  EXPECT_GT(bright, 100);
}

}  // namespace
}  // namespace lensfarm
