// The light tree (render/light_tree.h, light/light_bounds.h): a light's bounds never rule out light
// it sends; the tree chooses each light with exactly the probability pmf() gives, bit for bit;
// the image with the tree is the image without it (per-pixel z-test), at the origin, a million
// units away, at 1e-4 and 1e4 scale, with NEE alone and in fog (equiangular sampling); it lowers
// the noise of a scene of many lights; and the effect analysis turns it on past
// kLightTreeAutoLights lights, saying why.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "common/light/light_bounds.h"
#include "common/render/light_tree.h"
#include "common/render/render_scene.h"
#include "common/scene/effects.h"
#include "tests/support/placement.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

Vec3 randomDirection(std::mt19937& rng) {
  std::normal_distribution<float> g;
  for (;;) {
    const Vec3 v(g(rng), g(rng), g(rng));
    if (glm::length(v) > 1e-3f) return glm::normalize(v);
  }
}

// A random light of each kind at scale `scale` around `centre`: a triangle (one- or two-sided),
// a point or a spot, with its bounds and a predicate telling whether it sends light to a point.
struct TestLight {
  LightBounds bounds;
  Vec3 v0, v1, v2, n;  // the triangle's, or the point's position in v0 and the spot's axis in n
  int kind;            // 0 triangle, 1 point, 2 spot
  float cosCone = -1.0f;

  bool lights(const Vec3& p) const {
    if (kind == 1) return true;
    if (kind == 2) return glm::dot(glm::normalize(p - v0), n) > cosCone;
    // A triangle lights p if some point of it sees p from its front (or either face when two-sided):
    // p off its plane, on the front side.
    const float side = glm::dot(p - v0, n);
    return bounds.twoSided ? side != 0.0f : side > 0.0f;
  }
};

TestLight randomLight(std::mt19937& rng, const Vec3& centre, float scale) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  TestLight l;
  l.kind = int(u(rng) * 3.0f) % 3;
  const Vec3 at = centre + scale * Vec3(8.0f * u(rng) - 4.0f, 8.0f * u(rng) - 4.0f, 8.0f * u(rng) - 4.0f);
  const float intensity = 0.1f + 10.0f * u(rng);
  if (l.kind == 0) {
    l.v0 = at, l.v1 = at + 0.3f * scale * randomDirection(rng), l.v2 = at + 0.3f * scale * randomDirection(rng);
    l.n = glm::normalize(glm::cross(l.v1 - l.v0, l.v2 - l.v0));
    l.bounds = LightBounds{glm::min(l.v0, glm::min(l.v1, l.v2)),
                           glm::max(l.v0, glm::max(l.v1, l.v2)),
                           intensity,
                           DirectionCone{l.n, 1.0f},
                           0.0f,
                           u(rng) < 0.3f};
  } else if (l.kind == 1) {
    l.v0 = at;
    l.bounds = LightBounds{at, at, intensity, DirectionCone::sphere(), 0.0f, false};
  } else {
    l.v0 = at, l.n = randomDirection(rng);
    const float cone = 0.1f + 1.4f * u(rng), start = cone * u(rng);
    l.cosCone = std::cos(cone);
    l.bounds = LightBounds{at, at, intensity, DirectionCone{l.n, std::cos(start)}, std::cos(cone - start), false};
  }
  return l;
}

TEST(LightBounds, AClusterNeverRulesOutLightAnyOfItsLightsSends) {
  // Clusters of 1 to 64 random lights merged in random order: wherever one of them sends light,
  // the cluster's importance is positive (else the tree would never choose it there: bias).
  std::mt19937 rng(11);
  for (float scale : {1e-4f, 1.0f, 1e4f})
    for (int trial = 0; trial < 300; ++trial) {
      const Vec3 centre = trial % 2 ? Vec3(1e6f, -2e6f, 5e5f) * (scale / 1e4f) : Vec3(0.0f);
      std::vector<TestLight> lights;
      LightBounds cluster;
      const int n = 1 + trial % 64;
      for (int k = 0; k < n; ++k) {
        lights.push_back(randomLight(rng, centre, scale));
        cluster = LightBounds::merge(cluster, lights.back().bounds);
      }
      for (const TestLight& l : lights)
        if (l.kind != 1) {
          EXPECT_GE(glm::dot(cluster.normals.w, l.n), cluster.normals.cosTheta - 1e-5f);
        }
      for (int q = 0; q < 20; ++q) {
        const Vec3 p = centre + scale * Vec3(20.0f * std::uniform_real_distribution<float>(-1, 1)(rng),
                                             20.0f * std::uniform_real_distribution<float>(-1, 1)(rng),
                                             20.0f * std::uniform_real_distribution<float>(-1, 1)(rng));
        bool lit = false;
        for (const TestLight& l : lights) lit |= l.lights(p);
        if (lit) {
          ASSERT_GT(LightCluster(cluster).importance(p), 0.0f) << "scale " << scale << ", trial " << trial;
        }
      }
    }
}

TEST(LightBounds, ImportanceIsZeroOnlyWhereNothingCanBeLit) {
  const auto importance = [](const LightBounds& b, const Vec3& p) { return LightCluster(b).importance(p); };
  // A one-sided square facing +z: nothing behind it, something in front, and both sides two-sided.
  const LightBounds square{Vec3(-1, -1, 0), Vec3(1, 1, 0), 2.0f, DirectionCone{Vec3(0, 0, 1), 1.0f}, 0.0f, false};
  EXPECT_GT(importance(square, Vec3(5, 0, 0.01f)), 0.0f) << "grazing, in front";
  EXPECT_EQ(importance(square, Vec3(0, 0, -3)), 0.0f) << "behind";
  EXPECT_EQ(importance(square, Vec3(5, 0, -3)), 0.0f) << "behind, off to the side";
  LightBounds twoSided = square;
  twoSided.twoSided = true;
  EXPECT_GT(importance(twoSided, Vec3(0, 0, -3)), 0.0f);
  // Nearer is more important, as 1 / d^2 far away.
  EXPECT_NEAR(importance(square, Vec3(0, 0, 100)) / importance(square, Vec3(0, 0, 200)), 4.0, 0.01);
  // A hard-edged spot (falloff_start = cone_angle: theta_e = 0) is important inside its cone.
  const LightBounds spot{Vec3(0.0f), Vec3(0.0f), 1.0f, DirectionCone{Vec3(0, -1, 0), std::cos(0.5f)}, 1.0f, false};
  EXPECT_GT(importance(spot, Vec3(0, -5, 0)), 0.0f);
  EXPECT_GT(importance(spot, Vec3(2, -5, 0)), 0.0f);  // 0.38 rad off the axis
  EXPECT_EQ(importance(spot, Vec3(5, -1, 0)), 0.0f);  // 1.37 rad off
}

// The tree's choice from p over stratified u: every light that can light p has a positive pmf
// (else the estimate would miss its light), every light's frequency is its pmf, and the pmf a
// sample reports is pmf()'s, bit for bit. The pmfs sum to at most 1: a descent ends without a
// light where neither child can light p (a cluster's bounds are looser than its children's), as
// often as the rest of 1.
void expectTreeChoosesByItsPmf(const std::vector<TestLight>& lights, const LightTree& tree, const Vec3& p) {
  std::vector<double> pmf(lights.size());
  double sum = 0.0;
  int lit = 0;
  for (uint32_t i = 0; i < lights.size(); ++i) {
    sum += pmf[i] = tree.pmf(p, i);
    if (lights[i].lights(p)) {
      ++lit;
      ASSERT_GT(pmf[i], 0.0) << "light " << i << " lights p but is never chosen there";
    }
  }
  ASSERT_GT(lit, 0);
  const int n = 1 << 16;
  std::vector<int> count(lights.size());
  int none = 0;
  for (int k = 0; k < n; ++k) {
    const auto c = tree.sample(p, (float(k) + 0.5f) / float(n));
    if (!c) {
      ++none;
      continue;
    }
    ++count[c->light];
    ASSERT_EQ(c->pmf, tree.pmf(p, c->light)) << "light " << c->light;
    ASSERT_TRUE(lights[c->light].lights(p) || lights[c->light].kind == 0) << "chose a spot that cannot light p";
  }
  EXPECT_LE(sum, 1.0 + 1e-5);
  EXPECT_NEAR(double(none) / n, 1.0 - sum, 1e-3);
  // Stratified u: a light's count is its pmf times n within the levels' rounding, a few samples.
  for (size_t i = 0; i < lights.size(); ++i)
    ASSERT_NEAR(count[i], pmf[i] * n, 2.0 + 1e-3 * pmf[i] * n) << "light " << i;
}

TEST(LightTree, ChoosesEachLightWithThePmfItReportsAtAnyScaleAndPlace) {
  std::mt19937 rng(5);
  for (float scale : {1e-4f, 1.0f, 1e4f})
    for (const Vec3& centre : {Vec3(0.0f), Vec3(1e6f, 0.0f, -1e6f)}) {
      if (scale < 1.0f && centre != Vec3(0.0f)) continue;  // 1e-4 lengths do not exist at 1e6 in float
      SCOPED_TRACE(testing::Message() << "scale " << scale << " at " << centre.x);
      std::vector<TestLight> lights;
      std::vector<LightBounds> bounds;
      for (int k = 0; k < 300; ++k) {
        lights.push_back(randomLight(rng, centre, scale));
        bounds.push_back(lights.back().bounds);
      }
      const LightTree tree(bounds);
      ASSERT_FALSE(tree.empty());
      EXPECT_LE(tree.depth(), 40u);
      EXPECT_EQ(tree.nodeCount(), 2 * lights.size() - 1);
      for (int q = 0; q < 6; ++q)
        expectTreeChoosesByItsPmf(lights, tree, centre + scale * Vec3(6.0f * float(q) - 15.0f, 2.0f, 1.0f + float(q)));
    }
}

TEST(LightTree, HoldsOneLightAndAHundredThousand) {
  const LightBounds one{Vec3(0.0f), Vec3(0.0f), 1.0f, DirectionCone::sphere(), 0.0f, false};
  const LightTree single({one});
  const auto c = single.sample(Vec3(1.0f), 0.7f);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->light, 0u);
  EXPECT_EQ(c->pmf, 1.0f);
  EXPECT_EQ(single.pmf(Vec3(1.0f), 0), 1.0f);
  // Lights of zero intensity are left out; a tree of none chooses nothing.
  EXPECT_TRUE(LightTree({LightBounds{}}).empty());
  EXPECT_FALSE(LightTree({LightBounds{}}).sample(Vec3(0.0f), 0.5f));
  EXPECT_EQ(LightTree({LightBounds{}, one}).pmf(Vec3(1.0f), 0), 0.0f);
  // 100,000 points on a line (a degenerate box: every split along one axis) and as many at one
  // place (no split but by count): both within the 64 levels a trail holds.
  for (bool coincide : {false, true}) {
    std::vector<LightBounds> many;
    for (int k = 0; k < 100000; ++k) {
      const Vec3 at(coincide ? 0.0f : float(k), 0.0f, 0.0f);
      many.push_back(LightBounds{at, at, 1.0f + float(k % 7), DirectionCone::sphere(), 0.0f, false});
    }
    const LightTree tree(many);
    EXPECT_LT(tree.depth(), 64u);
    double sum = 0.0;
    for (uint32_t i = 0; i < many.size(); ++i) sum += tree.pmf(Vec3(5000.0f, 3.0f, 0.0f), i);
    EXPECT_NEAR(sum, 1.0, 1e-4) << (coincide ? "coinciding" : "on a line");
  }
}

// A room of many small lights: a floor and a ceiling 2 apart, a back wall, and a grid of
// side x side small quads between them (a third facing down, a third up, a third sideways, some
// two-sided, their radiance spread over 16x), with a point and a spot light; every length times
// `scale`, everything moved by `offset`.
json manyLightsScene(int side, double scale, const glm::dvec3& offset) {
  const test::PlacedPoint at{scale, offset};
  const test::ScaledVector v{scale};
  json j = json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "up": [0, 1, 0] },
    "materials": { "white": { "type": "lambertian", "albedo": 0.6 },
                   "red": { "type": "lambertian", "albedo": [0.6, 0.2, 0.2] } },
    "render": { "resolution": [20, 20], "samples_per_pixel": 8, "max_bounces": 2, "seed": 9 }
  })");
  j["camera"]["sensor_width"] = 0.036 * scale;
  j["camera"]["focal_length"] = 0.03 * scale;
  j["camera"]["position"] = at(0, 1, -4.5);
  j["camera"]["look_at"] = at(0, 0.8, 0);
  const auto quad = [&](json corner, json e1, json e2, const char* material) {
    j["shapes"].push_back({{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", material}});
  };
  quad(at(-3, 0, -3), v(0, 0, 6), v(6, 0, 0), "white");  // floor, facing up
  quad(at(-3, 2, -3), v(6, 0, 0), v(0, 0, 6), "white");  // ceiling, facing down
  quad(at(-3, 0, 2), v(6, 0, 0), v(0, 2, 0), "red");     // back wall, facing -z
  j["lights"] = json::array();
  uint32_t hash = 17;
  for (int a = 0; a < side; ++a)
    for (int b = 0; b < side; ++b) {
      hash = hash * 1664525u + 1013904223u;
      const double x = -2.5 + 5.0 * (a + 0.5) / side, z = -1.5 + 3.5 * (b + 0.5) / side,
                   y = 0.6 + 0.8 * ((a + b) % 5) / 4.0;
      const double s = 0.25, radiance = 0.5 * std::pow(2.0, double(hash >> 28) / 4.0);
      json q = {
          {"type", "quad"}, {"radiance", {radiance, radiance * 0.8, radiance * 0.6}}, {"visible_to_camera", true}};
      switch ((a + 2 * b) % 3) {
        case 0: q["corner"] = at(x, y, z), q["edge1"] = v(s, 0, 0), q["edge2"] = v(0, 0, s); break;   // down
        case 1: q["corner"] = at(x, y, z), q["edge1"] = v(0, 0, s), q["edge2"] = v(s, 0, 0); break;   // up
        default: q["corner"] = at(x, y, z), q["edge1"] = v(0, s, 0), q["edge2"] = v(0, 0, s); break;  // +x
      }
      q["two_sided"] = (hash >> 8) % 4 == 0;
      j["lights"].push_back(q);
    }
  j["lights"].push_back({{"type", "point"}, {"position", at(1.5, 1.8, 0.5)}, {"intensity", 0.5 * scale * scale}});
  j["lights"].push_back({{"type", "spot"},
                         {"position", at(-1.5, 1.9, -0.5)},
                         {"look_at", at(-1.2, 0, 0.5)},
                         {"intensity", 2.0 * scale * scale},
                         {"cone_angle", 35},
                         {"falloff_start", 20}});
  return j;
}

Scene withTree(const test::TempDir& dir, json j, const std::string& mode, const std::string& name) {
  j["render"]["light_tree"] = mode;
  return test::loadSceneJson(dir, j, name + "-" + mode + ".json");
}

void expectTreeAgrees(const test::TempDir& dir, json j, const std::string& name, int renders = 16) {
  SCOPED_TRACE(name);
  j["render"]["samples_per_pixel"] = 48;  // image means within 0.7 % (a wrong MIS weight: 6 % off)
  const Scene on = withTree(dir, j, "on", name), off = withTree(dir, j, "off", name);
  ASSERT_TRUE(RenderScene(on).lights().usesTree());
  ASSERT_FALSE(RenderScene(off).lights().usesTree());
  test::expectSameImage(test::renderStatistics(on, renders), test::renderStatistics(off, renders));
}

TEST(LightTree, TheImageIsTheSameWithAndWithoutTheTreeAtAnyScaleAndPlace) {
  test::TempDir dir;
  expectTreeAgrees(dir, manyLightsScene(6, 1.0, glm::dvec3(0.0)), "origin");
  expectTreeAgrees(dir, manyLightsScene(6, 1.0, glm::dvec3(1e6, -1e6, 1e6)), "at 1e6");
  expectTreeAgrees(dir, manyLightsScene(6, 1e-4, glm::dvec3(0.0)), "1e-4 scale");
  expectTreeAgrees(dir, manyLightsScene(6, 1e4, glm::dvec3(0.0)), "1e4 scale");
}

TEST(LightTree, TheImageIsTheSameWithNeeAloneWithASkyAndInFog) {
  test::TempDir dir;
  json nee = manyLightsScene(5, 1.0, glm::dvec3(0.0));
  nee["render"]["integrator"] = "nee";
  expectTreeAgrees(dir, nee, "nee");
  // A sun and a sky beyond the room's open sides: chosen by power before the tree.
  json sky = manyLightsScene(5, 1.0, glm::dvec3(0.0));
  sky["lights"].push_back({{"type", "directional"}, {"direction", {0.5, -0.2, 1}}, {"irradiance", 0.3}});
  sky["environment"] = {{"radiance", {0.05, 0.07, 0.1}}};
  expectTreeAgrees(dir, sky, "sky");
  // Fog: equiangular sampling (forced: auto leaves it off beside a tree) chooses its light point by
  // power, weighed against the tree's choice.
  json fog = manyLightsScene(5, 1.0, glm::dvec3(0.0));
  fog["media"]["fog"] = {{"sigma_s", 0.15}, {"sigma_a", 0.05}};
  fog["medium"] = "fog";
  fog["render"]["max_medium_bounces"] = 2;
  EXPECT_FALSE(RenderScene(withTree(dir, fog, "on", "fog-auto")).effects().equiangular);
  fog["render"]["medium_light_sampling"] = "equiangular";
  ASSERT_TRUE(RenderScene(withTree(dir, fog, "on", "fog-check")).effects().equiangular);
  expectTreeAgrees(dir, fog, "fog");
  // Without the tree, auto keeps equiangular sampling.
  fog["render"]["medium_light_sampling"] = "auto";
  EXPECT_TRUE(RenderScene(withTree(dir, fog, "off", "fog-power")).effects().equiangular);
}

TEST(LightTree, LowersTheNoiseOfARoomOfManyLightsAtEqualSamples) {
  // 400 small lights: by power, most samples go to lights far from the point or facing away.
  test::TempDir dir;
  const json j = manyLightsScene(20, 1.0, glm::dvec3(0.0));
  const test::ImageStatistics on = test::renderStatistics(withTree(dir, j, "on", "noise"), 12);
  const test::ImageStatistics off = test::renderStatistics(withTree(dir, j, "off", "noise"), 12);
  // Relative variance summed over the pixel-channels: the tree's lower by a third at least (1.46x
  // measured; the lights here all lie within a few metres of every point).
  double varOn = 0.0, varOff = 0.0;
  for (size_t k = 0; k < on.mean.size(); ++k) {
    const double m = std::max(0.5 * (on.mean[k] + off.mean[k]), 1e-3);
    varOn += on.variance[k] / (m * m), varOff += off.variance[k] / (m * m);
  }
  EXPECT_GT(varOff / varOn, 1.3) << "relative variance without the tree over with it";
}

TEST(LightTree, TheEffectAnalysisTurnsItOnPastItsThresholdAndSaysWhy) {
  test::TempDir dir;
  const auto decision = [&](const json& j, const std::string& name) {
    const Scene scene = test::loadSceneJson(dir, j, name + ".json");
    const RenderScene rs(scene);
    for (const EffectDecision& d : rs.effects().decisions)
      if (d.effect == "light tree") return d;
    return EffectDecision{"none", false, ""};
  };
  // The Cornell box's two triangles: no tree, and nothing said.
  EXPECT_EQ(decision(test::bundledSceneJson("cornell-classic.json"), "classic").effect, "none");
  EXPECT_FALSE(RenderScene(test::loadSceneJson(dir, test::bundledSceneJson("cornell-classic.json"), "c.json"))
                   .lights()
                   .usesTree());
  // 5 x 5 quads: 50 triangles and 2 lights at points (52 <= 64): by power, said so.
  const EffectDecision few = decision(manyLightsScene(5, 1.0, glm::dvec3(0.0)), "few");
  EXPECT_FALSE(few.simulated);
  EXPECT_NE(few.reason.find("52 light(s)"), std::string::npos) << few.reason;
  // 6 x 6: 74: the tree.
  const EffectDecision many = decision(manyLightsScene(6, 1.0, glm::dvec3(0.0)), "many");
  EXPECT_TRUE(many.simulated) << many.reason;
  EXPECT_NE(many.reason.find("72 emitting triangle(s) and 2 point or spot"), std::string::npos) << many.reason;
  // Forced either way.
  json forced = test::bundledSceneJson("cornell-classic.json");
  forced["render"]["light_tree"] = "on";
  EXPECT_TRUE(decision(forced, "forced-on").simulated);
  json off = manyLightsScene(6, 1.0, glm::dvec3(0.0));
  off["render"]["light_tree"] = "off";
  EXPECT_FALSE(decision(off, "forced-off").simulated);
  EXPECT_NE(decision(off, "forced-off").reason.find("render.light_tree is off"), std::string::npos);
  // A bad mode names the field.
  json bad = test::bundledSceneJson("cornell-classic.json");
  bad["render"]["light_tree"] = "sometimes";
  try {
    test::loadSceneJson(dir, bad, "bad.json");
    ADD_FAILURE() << "accepted light_tree \"sometimes\"";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("render.light_tree"), std::string::npos) << e.what();
  }
}

TEST(LightTree, AHundredThousandEmittersRender) {
  // 50,000 quads (100,000 triangles) and one light at a point: built, chosen, rendered.
  test::TempDir dir;
  json j = manyLightsScene(224, 1.0, glm::dvec3(0.0));
  j["render"]["resolution"] = {8, 8};
  j["render"]["samples_per_pixel"] = 2;
  const Scene scene = test::loadSceneJson(dir, j);
  const RenderScene rs(scene);
  ASSERT_TRUE(rs.lights().usesTree());
  EXPECT_EQ(rs.lights().size(), 224u * 224u * 2u + 2u);
  EXPECT_LT(rs.lights().tree().depth(), 64u);
  const test::Rendered r = test::renderScene(scene);
  double sum = 0.0;
  for (float x : r.image.rgb) sum += x;
  EXPECT_GT(sum, 0.0);
  EXPECT_TRUE(std::isfinite(sum));
}

}  // namespace
}  // namespace lensfarm
