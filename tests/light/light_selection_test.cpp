// Choosing a light for next-event estimation (render/light_sampler.h): every kind of light in
// proportion to its power (triangle pi A L, point 4 pi I, spot 2 pi I (1 - (cos start + cos
// total) / 2), directional pi r^2 E, environment pi r^2 times its integral), a scene of emitting
// triangles alone exactly as before the other lights existed, and the naive estimator's sampler
// holding the delta lights alone.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "common/math/triangle.h"
#include "common/render/light_sampler.h"
#include "common/render/render_scene.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;
constexpr double kPi = std::numbers::pi;

// The camera at (0, 0, -3) looking at a white square [-1, 1]^2 at z = 0; lights as given.
json selectionScene(const json& lights) {
  json scene = test::minimalSceneJson();
  scene["lights"] = lights;
  return scene;
}

const json kQuad = {{"type", "quad"},
                    {"corner", {-0.5, -0.25, -1}},
                    {"edge1", {1, 0, 0}},
                    {"edge2", {0, 0.5, 0}},
                    {"radiance", {3, 2, 1}}};  // area 0.5, facing +z (the square)
const json kPoint = {{"type", "point"}, {"position", {0.5, 0.5, -2}}, {"intensity", {2, 2, 2}}};
const json kSpot = {{"type", "spot"}, {"position", {0, 1, -0.5}}, {"direction", {0, -1, 0}},
                    {"intensity", 4}, {"cone_angle", 40},         {"falloff_start", 30}};
const json kSun = {{"type", "directional"}, {"direction", {0, 1, -1}}, {"irradiance", 0.25}};

double lum(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

TEST(LightSelection, ChoosesEveryKindOfLightInProportionToItsPower) {
  json scene = selectionScene({kQuad, kPoint, kSpot, kSun});
  scene["environment"] = {{"radiance", {0.1, 0.2, 0.3}}};
  test::TempDir dir;
  const Scene loaded = test::loadSceneJson(dir, scene);
  const RenderScene rs(loaded);
  const LightSampler& lights = rs.lights();
  ASSERT_EQ(lights.size(), 2u + 4u);  // the quad's two triangles, then the other four

  // The bounding sphere of everything and the camera: the box [-1, 1] x [-1, 1] x [-3, 0].
  const double r = 0.5 * std::sqrt(4.0 + 4.0 + 9.0);
  EXPECT_NEAR(lights.sceneSphere().radius, r, 3e-6 * r);  // rounded up by 1e-6
  const double quad = kPi * 0.5 * lum(3, 2, 1), point = 4 * kPi * 2,
               spot = 2 * kPi * 4 * (1 - 0.5 * (std::cos(30 * kPi / 180) + std::cos(40 * kPi / 180))),
               sun = kPi * r * r * 0.25, environment = kPi * r * r * 4 * kPi * lum(0.1, 0.2, 0.3);
  const double total = quad + point + spot + sun + environment;
  const std::map<std::string, double> expected = {{"quad", quad / total},
                                                  {"point", point / total},
                                                  {"spot", spot / total},
                                                  {"sun", sun / total},
                                                  {"environment", environment / total}};

  // A shading point on the camera's side of the square, lit by every light (in the spot's cone).
  const Vec3 ref(0.0f, 0.0f, 2.5f);  // (0, 0, -0.5) in the file: render space is camera-centred
  const Vec3 pointAt(0.5f, 0.5f, 1.0f), spotAt(0.0f, 1.0f, 2.5f);
  std::map<std::string, int> chosen;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const auto s = lights.sample(ref, (float(k) + 0.5f) / float(n), Vec2(0.3f, 0.6f));
    ASSERT_TRUE(s) << k;
    std::string which;
    if (s->n != Vec3(0.0f))
      which = "quad";
    else if (s->delta && s->p == pointAt)
      which = "point";
    else if (s->delta && s->p == spotAt)
      which = "spot";
    else if (s->delta)
      which = "sun";
    else
      which = "environment";
    ++chosen[which];
    // A delta light's pdf is the probability of choosing it.
    if (which == "point" || which == "spot" || which == "sun") {
      ASSERT_NEAR(s->pdf, expected.at(which), 1e-5 * expected.at(which)) << which;
    }
    // An infinite light's shadow ray ends 3 r away: beyond the sphere.
    if (which == "sun" || which == "environment") {
      ASSERT_NEAR(glm::length(s->p - ref) * s->reach, 3.0 * r, 1e-5 * r) << which;
    } else {
      ASSERT_EQ(s->reach, which == "quad" ? 0.0f : 1.0f);
    }
  }
  for (const auto& [which, p] : expected) EXPECT_NEAR(double(chosen[which]) / n, p, 2e-4) << which;
  ASSERT_EQ(lights.escapeLights().size(), 1u);
  EXPECT_NEAR(lights.escapeLights()[0].pmf, expected.at("environment"), 1e-5 * expected.at("environment"));
}

// The rule emitting triangles were always chosen by, written out: power p_i = A_i L_i (x2 when
// two-sided) in double, pmf_i = float(p_i / sum), cdf_i = float(running double sum), the last 1;
// a light is the first whose cdf entry is above uChoice.
TEST(LightSelection, AnEmittingTriangleSceneChoosesExactlyAsItAlwaysHas) {
  for (int quads : {2, 7}) {  // 4 triangles (chosen in the lane loops by selects), 14 (gathered)
    SCOPED_TRACE(quads);
    json lights = json::array();
    for (int q = 0; q < quads; ++q)
      lights.push_back({{"type", "quad"},
                        {"corner", {-0.9 + 0.25 * q, -0.5, -1}},
                        {"edge1", {0.2, 0, 0}},
                        {"edge2", {0, 0.1 + 0.07 * q, 0}},
                        {"radiance", {1.0 + q, 0.5, 2.0 - 0.2 * q}},
                        {"two_sided", q % 3 == 0}});
    test::TempDir dir;
    const Scene loaded = test::loadSceneJson(dir, selectionScene(lights));
    const RenderScene rs(loaded);
    std::vector<double> power;
    std::vector<uint32_t> triangles;
    double total = 0.0;
    for (uint32_t t = 0; t < rs.caster().triangles().size(); ++t) {
      const auto& tri = rs.caster().triangles()[t];
      const Material& m = loaded.materials[tri.material];
      if (!m.isEmissive()) continue;
      const double p = double(float(triangleArea(tri.v0, tri.v1, tri.v2))) * luminance(m.emission) *
                       (m.twoSidedEmission ? 2.0 : 1.0);
      power.push_back(p);
      triangles.push_back(t);
      total += p;
    }
    ASSERT_EQ(power.size(), size_t(2 * quads));
    std::vector<float> cdf;
    double running = 0.0;
    for (size_t i = 0; i < power.size(); ++i) {
      const auto& tri = rs.caster().triangles()[triangles[i]];
      // pdf at distance 1 straight along the normal: the pmf over the area, bit for bit.
      const float pmf = float(power[i] / total), area = float(triangleArea(tri.v0, tri.v1, tri.v2));
      EXPECT_EQ(rs.lights().pdf(triangles[i], Vec3(0.0f), 1.0f, tri.n), pmf * 1.0f * 1.0f / (1.0f * area)) << i;
      running += power[i] / total;
      cdf.push_back(float(running));
    }
    cdf.back() = 1.0f;
    const Vec3 ref(0.0f, 0.0f, 2.5f);
    for (int k = 0; k < 4096; ++k) {
      const float u = float(k) / 4096.0f;
      const size_t want = std::min(size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()), cdf.size() - 1);
      const auto s = rs.lights().sample(ref, u, Vec2(0.25f, 0.5f));
      ASSERT_TRUE(s);
      ASSERT_EQ(s->v0, rs.caster().triangles()[triangles[want]].v0) << "uChoice " << u;
    }
  }
}

TEST(LightSelection, OtherLightsTakeTheirShareWithoutChangingTheTrianglesRelativeChoice) {
  test::TempDir dir;
  const Scene alone = test::loadSceneJson(dir, selectionScene(json::array({kQuad})), "alone.json");
  const Scene mixed = test::loadSceneJson(dir, selectionScene({kQuad, kPoint}), "mixed.json");
  const RenderScene a(alone), b(mixed);
  const auto& tri = a.caster().triangles()[2];  // the quad light's first triangle (the square is 0 and 1)
  ASSERT_TRUE(alone.materials[tri.material].isEmissive());
  const double quad = kPi * 0.5 * lum(3, 2, 1), point = 4 * kPi * 2;
  EXPECT_NEAR(b.lights().pdf(2, Vec3(0.0f), 1.0f, tri.n) / a.lights().pdf(2, Vec3(0.0f), 1.0f, tri.n),
              quad / (quad + point), 1e-6);
}

TEST(LightSelection, TheNaiveEstimatorSamplesTheDeltaLightsAlone) {
  json scene = selectionScene(
      {kQuad,
       kPoint,
       kSpot,
       kSun,
       {{"type", "directional"}, {"direction", {0, 0, -1}}, {"irradiance", 1}, {"angular_diameter", 5}}});
  scene["environment"] = {{"radiance", 1}};
  scene["render"]["integrator"] = "naive";
  test::TempDir dir;
  const Scene loaded = test::loadSceneJson(dir, scene);
  const RenderScene rs(loaded);
  EXPECT_EQ(rs.lights().size(), 3u);  // point, spot, the sun without a diameter
  EXPECT_TRUE(rs.lights().hasDeltaLights());
  ASSERT_EQ(rs.lights().escapeLights().size(), 2u);  // the finite sun and the environment: never sampled
  for (const auto& e : rs.lights().escapeLights()) EXPECT_EQ(e.pmf, 0.0f);
  for (int k = 0; k < 100; ++k) {
    const auto s = rs.lights().sample(Vec3(0.0f, 0.0f, 2.5f), float(k) / 100.0f, Vec2(0.5f));
    ASSERT_TRUE(s);
    EXPECT_TRUE(s->delta);
  }
  EXPECT_EQ(rs.lights().pdf(2, Vec3(0.0f), 1.0f, rs.caster().triangles()[2].n), 0.0f)
      << "the quad is left to scattered rays";
}

}  // namespace
}  // namespace lensfarm
