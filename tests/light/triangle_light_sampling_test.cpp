// Light samples on emitting triangles by solid angle near them (render/light_sampler.h,
// render.triangle_light_sampling): the irradiance just behind a two-sided lamp against Lambert's
// closed form, with bounded estimates where sampling by area gives rare huge ones; the density a
// hit on the light is weighed by equal to the sample's; and images the same (per-pixel test) with
// points by area, by solid angle and mixed, in a room and in fog, at any scale and place.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "common/render/light_sampler.h"
#include "common/render/render_scene.h"
#include "tests/support/uniform_rng.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

json at(const glm::dvec3& origin, double scale, double x, double y, double z) {
  const glm::dvec3 p = origin + scale * glm::dvec3(x, y, z);
  return {p.x, p.y, p.z};
}
json edge(double scale, double x, double y, double z) { return {scale * x, scale * y, scale * z}; }

// A white wall at z = 0 seen from z = -3, and a two-sided 1 x 1 lamp at z = -1 facing it, all
// scaled by `scale` about `origin`.
json lampScene(const glm::dvec3& origin, double scale, const std::string& mode) {
  json j = test::minimalSceneJson();
  j["camera"]["position"] = at(origin, scale, 0, 0, -3);
  j["camera"]["look_at"] = at(origin, scale, 0, 0, 0);
  j["camera"]["sensor_width"] = 0.1 * scale, j["camera"]["focal_length"] = 0.1 * scale;
  j["shapes"][0]["corner"] = at(origin, scale, -1, -1, 0);
  j["shapes"][0]["edge1"] = edge(scale, 0, 2, 0), j["shapes"][0]["edge2"] = edge(scale, 2, 0, 0);
  j["lights"] = json::array({{{"type", "quad"},
                              {"corner", at(origin, scale, -0.5, -0.5, -1)},
                              {"edge1", edge(scale, 1, 0, 0)},
                              {"edge2", edge(scale, 0, 1, 0)},
                              {"radiance", 5},
                              {"two_sided", true}}});
  j["render"]["triangle_light_sampling"] = mode;
  return j;
}

// Irradiance over radiance at height d above the centre of a 2a x 2a square, facing it: four
// times a rectangle's seen from above its corner, (1/2)(X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + (X <-> Y))
// with X = Y = a / d (the form factor of a parallel rectangle, e.g. Howell's catalogue, C-11).
double squareIrradianceOverRadiance(double a, double d) {
  const double x = a / d, r = std::sqrt(1.0 + x * x);
  return 4.0 * 0.5 * (2.0 * x / r * std::atan(x / r));
}

struct Estimate {
  double mean = 0.0, relativeSpread = 0.0;  // the sample standard deviation over the mean
  int samples = 0;
};

// Next-event estimates of the irradiance at ref (facing `normal`) from the scene's lights, and
// each sample's density checked against the one a ray hitting the light is weighed by.
Estimate irradiance(const RenderScene& rs, const Vec3& ref, const Vec3& normal) {
  test::UniformRng rng(5);
  constexpr int kSamples = 20000;
  double sum = 0.0, sum2 = 0.0;
  for (int k = 0; k < kSamples; ++k) {
    const float uChoice = rng.next();
    const auto s = rs.lights().sample(ref, uChoice, rng.next2());
    if (!s) continue;
    const Vec3 toLight = s->p - ref;
    const float distance = glm::length(toLight);
    const Vec3 d = toLight / distance;
    const double e = double(s->radiance.g) * std::max(0.0f, glm::dot(normal, d)) / s->pdf;
    sum += e, sum2 += e * e;
    // The triangle sampled (of the lamp's two, of equal power, the first below its cdf entry),
    // and the density pdf() gives a ray from ref that hits it there.
    const auto& lights = rs.lights().triangleLights();
    const auto& l = lights[uChoice < lights[0].pmf ? 0 : 1];
    const float hitPdf = rs.lights().pdf(l.triangle, ref, distance, d);
    EXPECT_NEAR(hitPdf, s->pdf, 1e-4f * s->pdf) << "sample " << k;
  }
  const double mean = sum / kSamples, variance = sum2 / kSamples - mean * mean;
  return {mean, std::sqrt(std::max(0.0, variance)) / mean, kSamples};
}

// Both scenes' light samplers give ref the same point with the same density (the same bits).
void expectTheSameSample(const RenderScene& a, const RenderScene& b, const Vec3& ref) {
  const auto sa = a.lights().sample(ref, 0.3f, Vec2(0.2f, 0.7f));
  const auto sb = b.lights().sample(ref, 0.3f, Vec2(0.2f, 0.7f));
  ASSERT_TRUE(sa && sb);
  EXPECT_EQ(sa->p, sb->p);
  EXPECT_EQ(sa->pdf, sb->pdf);
}

TEST(TriangleLightSampling, JustBehindATwoSidedLampTheEstimateIsBoundedAndUnbiasedAtAnyScaleAndPlace) {
  for (const double scale : {1e-4, 1.0, 1e4})
    for (const glm::dvec3 origin : {glm::dvec3(0.0), glm::dvec3(1e6, -1e6, 1e6)}) {
      SCOPED_TRACE("scale " + std::to_string(scale) + ", origin x " + std::to_string(origin.x));
      test::TempDir dir;
      const Scene autoScene = test::loadSceneJson(dir, lampScene(origin, scale, "auto"), "auto.json");
      const Scene areaScene = test::loadSceneJson(dir, lampScene(origin, scale, "area"), "area.json");
      const RenderScene automatic(autoScene), byArea(areaScene);
      const auto& lights = automatic.lights().triangleLights();
      ASSERT_EQ(lights.size(), 2u);
      const auto& l = lights[0];
      // The lamp's centre in render space, and a point 1e-3 of its size behind it.
      Vec3 lo = l.v0, hi = l.v0;
      for (const auto& t : lights)
        for (const Vec3& v : {t.v0, t.v1, t.v2}) lo = glm::min(lo, v), hi = glm::max(hi, v);
      const Vec3 centre = 0.5f * (lo + hi);
      const float h = float(1e-3 * scale);
      const Vec3 ref = centre - h * l.n;
      ASSERT_TRUE(LightSampler::bySolidAngle(l, ref));
      const double expected = 5.0 * squareIrradianceOverRadiance(0.5 * scale, double(h));
      const Estimate a = irradiance(automatic, ref, l.n), b = irradiance(byArea, ref, l.n);
      EXPECT_NEAR(a.mean, expected, 0.01 * expected) << "by solid angle";
      // By solid angle each estimate is L cos Omega / pmf, its spread that of cos over nearly a
      // hemisphere: 1 / sqrt(3) of the mean (E cos = 1/2, E cos^2 = 1/3), a little more as the
      // triangles are chosen by area, not by Omega. By area it is L cos cos' A / (pmf d^2), up to
      // 10^6 times its mean: the fireflies.
      EXPECT_LT(a.relativeSpread, 0.65);
      EXPECT_GT(b.relativeSpread, 20.0 * a.relativeSpread);
      // Far away, both take the point by area: the same bits.
      const Vec3 far = centre - float(10.0 * scale) * l.n;
      ASSERT_FALSE(LightSampler::bySolidAngle(l, far));
      expectTheSameSample(automatic, byArea, far);
    }
}

TEST(TriangleLightSampling, ALightWithNoSurfaceWithinReachKeepsTheAreaMapAndItsBits) {
  // Path vertices lie on surfaces: with the wall moved far from the lamp, nothing can be near it,
  // so even a point just behind it is sampled by area (the same bits as "area"), and the lane
  // loops skip the test. In fog a vertex can be anywhere: there the lamp keeps its reach.
  test::TempDir dir;
  json far = lampScene(glm::dvec3(0.0), 1.0, "auto");
  far["shapes"][0]["corner"] = {-1, -1, 20};
  json farArea = far;
  farArea["render"]["triangle_light_sampling"] = "area";
  const Scene autoScene = test::loadSceneJson(dir, far, "auto.json"),
              areaScene = test::loadSceneJson(dir, farArea, "area.json");
  const RenderScene automatic(autoScene), byArea(areaScene);
  const auto& l = automatic.lights().triangleLights()[0];
  const Vec3 ref = l.centroid - 1e-3f * l.n;
  EXPECT_FALSE(LightSampler::bySolidAngle(l, ref));
  expectTheSameSample(automatic, byArea, ref);

  // Asked for by name, the solid-angle map is taken everywhere all the same.
  json farSolidAngle = far;
  farSolidAngle["render"]["triangle_light_sampling"] = "solid_angle";
  const Scene forcedScene = test::loadSceneJson(dir, farSolidAngle, "forced.json");
  const RenderScene forced(forcedScene);
  EXPECT_TRUE(LightSampler::bySolidAngle(forced.lights().triangleLights()[0], ref));
  EXPECT_TRUE(LightSampler::bySolidAngle(forced.lights().triangleLights()[0], ref - 1e3f * l.n));

  json foggy = far;
  foggy["media"]["fog"] = {{"sigma_s", 0.05}, {"sigma_a", 0.01}};
  foggy["medium"] = "fog";
  const Scene fogScene = test::loadSceneJson(dir, foggy, "fog.json");
  const RenderScene fog(fogScene);
  EXPECT_TRUE(LightSampler::bySolidAngle(fog.lights().triangleLights()[0], ref));
}

TEST(TriangleLightSampling, AUnknownModeIsRefusedNamingTheField) {
  test::TempDir dir;
  try {
    test::loadSceneJson(dir, lampScene(glm::dvec3(0.0), 1.0, "spherical"));
    FAIL() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("render.triangle_light_sampling"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("solid_angle"), std::string::npos) << e.what();
  }
}

// A room (floor, ceiling, back wall) with a two-sided lamp `gap` below the ceiling, as a glTF
// lamp exported from Blender often is; optionally filled with fog.
json roomScene(const glm::dvec3& origin, double scale, double gap, const std::string& mode, bool fog) {
  auto wall = [&](json corner, json e1, json e2) {
    return json{{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", "white"}};
  };
  json j = {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "pinhole"},
        {"position", at(origin, scale, 0, 0.5, -2.5)},
        {"look_at", at(origin, scale, 0, 0.6, 0)},
        {"up", {0, 1, 0}},
        {"sensor_width", 0.1 * scale},
        {"focal_length", 0.06 * scale}}},
      {"materials", {{"white", {{"type", "lambertian"}, {"albedo", 0.7}}}}},
      {"shapes", json::array({wall(at(origin, scale, -1, 0, -1), edge(scale, 0, 0, 2), edge(scale, 2, 0, 0)),
                              wall(at(origin, scale, -1, 1, -1), edge(scale, 2, 0, 0), edge(scale, 0, 0, 2)),
                              wall(at(origin, scale, -1, 0, 1), edge(scale, 0, 1, 0), edge(scale, 2, 0, 0))})},
      {"lights", json::array({{{"type", "quad"},
                               {"corner", at(origin, scale, -0.3, 1.0 - gap, -0.3)},
                               {"edge1", edge(scale, 0.6, 0, 0)},
                               {"edge2", edge(scale, 0, 0, 0.6)},
                               {"radiance", 4},
                               {"two_sided", true}}})},
      {"render",
       {{"resolution", {16, 16}}, {"samples_per_pixel", 48}, {"max_bounces", 3}, {"triangle_light_sampling", mode}}},
  };
  if (fog) {
    j["media"]["fog"] = {{"sigma_s", 0.3 / scale}, {"sigma_a", 0.05 / scale}};
    j["medium"] = "fog";
    j["render"]["max_medium_bounces"] = 2;
    j["render"]["medium_light_sampling"] = "equiangular";
  }
  return j;
}

void expectModesAgree(const glm::dvec3& origin, double scale, double gap, bool fog, const std::string& a,
                      const std::string& b) {
  SCOPED_TRACE(a + " vs " + b + ", scale " + std::to_string(scale) + ", gap " + std::to_string(gap) +
               (fog ? ", fog" : ""));
  test::TempDir dir;
  const Scene sa = test::loadSceneJson(dir, roomScene(origin, scale, gap, a, fog), "a.json");
  const Scene sb = test::loadSceneJson(dir, roomScene(origin, scale, gap, b, fog), "b.json");
  test::expectSameImage(test::renderStatistics(sa, 16), test::renderStatistics(sb, 16));
}

TEST(TriangleLightSampling, TheImageIsTheSameByAreaBySolidAngleAndMixedAtAnyScaleAndPlace) {
  // A gap of 0.15 keeps sampling by area's tails light enough for a per-pixel test; 0.01 does not,
  // and is checked between the two bounded strategies.
  expectModesAgree(glm::dvec3(0.0), 1.0, 0.15, false, "auto", "area");
  expectModesAgree(glm::dvec3(0.0), 1.0, 0.01, false, "auto", "solid_angle");
  expectModesAgree(glm::dvec3(1e6, 1e6, -1e6), 1e-4, 0.01, false, "auto", "solid_angle");
  expectModesAgree(glm::dvec3(-1e6, 0.0, 0.0), 1e4, 0.15, false, "auto", "area");
}

TEST(TriangleLightSampling, TheImageIsTheSameInFogWhereEquiangularSamplingTakesItsPointByArea) {
  expectModesAgree(glm::dvec3(0.0), 1.0, 0.15, true, "auto", "area");
  expectModesAgree(glm::dvec3(0.0), 1.0, 0.01, true, "auto", "solid_angle");
  // Every light sample in the fog and on the walls by one map against the other.
  expectModesAgree(glm::dvec3(0.0), 1.0, 0.15, true, "solid_angle", "area");
}

}  // namespace
}  // namespace lensfarm
