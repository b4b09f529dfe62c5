// Russian roulette (render.russian_roulette, scene.h RouletteRule; render/integrator.cpp
// survivesRoulette): unbiased where it ends most paths, never before the minimum bounces, the
// same bits for any thread count and for packets and single rays, and the scene format's forms.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>

#include "common/render/unit_renderer.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A closed box whose walls all emit Le = 1 and reflect a: a path of B bounces sees
// Le (1 + a + ... + a^B) (2013 report §4.5), whatever the rule, if the rule is unbiased.
double geometricSeries(double a, int bounces) {
  double sum = 0.0;
  for (int k = 0; k <= bounces; ++k) sum += std::pow(a, k);
  return sum;
}

TEST(Roulette, EveryRuleKeepsTheFurnaceMeanOfAHighAlbedoBox) {
  // a = 0.9 and B = 12: the paths are long and their throughput falls to 0.28, so roulette ends
  // most of them early. Naive (every scattered ray lands on an emitter) and NEE + MIS. The means
  // with roulette agree with the exact answer and with roulette off; the rays per path show that
  // roulette did fire (else the comparison would prove nothing).
  const double a = 0.9;
  const int bounces = 12;
  const double expected = geometricSeries(a, bounces);
  for (const char* integrator : {"naive", "nee_mis"}) {
    double raysOff = 0.0;
    for (const char* rule : {"off", "max", "throughput"}) {
      SCOPED_TRACE(std::string(integrator) + ", roulette " + rule);
      test::TempDir dir;
      json scene =
          test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", a}, {"emission", 1.0}}, 24, 64, bounces);
      scene["render"]["integrator"] = integrator;
      scene["render"]["russian_roulette"] = rule;
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      // 36864 paths; the relative standard error of the mean is below 0.3 % for every rule here.
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], expected, 0.01 * expected);
      EXPECT_EQ(r.stats.dropped, 0u);
      const double raysPerPath = double(r.stats.rays) / double(r.stats.paths);
      if (std::string(rule) == "off")
        raysOff = raysPerPath;
      else
        EXPECT_LT(raysPerPath, 0.8 * raysOff) << "roulette ended too few paths for the test to mean anything";
    }
  }
}

TEST(Roulette, NeverEndsAPathBeforeTheMinimumBounces) {
  // Albedo 0.02: past the minimum, roulette ends nearly every path at once (q = sqrt(0.02^k) <=
  // 0.14 with the throughput rule, 0.02^k <= 0.02 with max). In a closed box every ray hits a
  // wall, so a path that roulette spares until bounce m + 1 casts at least m + 1 rays (the camera
  // ray and m scattered ones) with the naive estimator: fewer means a path was ended too early.
  const int bounces = 10;
  for (const char* rule : {"max", "throughput"})
    for (int minimum : {0, 1, 3}) {
      SCOPED_TRACE(std::string(rule) + ", minimum " + std::to_string(minimum));
      test::TempDir dir;
      json scene =
          test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.02}, {"emission", 1.0}}, 16, 16, bounces);
      scene["render"]["integrator"] = "naive";
      scene["render"]["russian_roulette"] = rule;
      scene["render"]["roulette_min_bounces"] = minimum;
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      const double raysPerPath = double(r.stats.rays) / double(r.stats.paths);
      EXPECT_GE(raysPerPath, double(minimum + 1));
      EXPECT_LT(raysPerPath, double(minimum + 1) + 0.2) << "roulette should end nearly every path right after";
      const double expected = geometricSeries(0.02, bounces);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c], expected, 0.01 * expected);
    }
}

TEST(Roulette, SameBitsForAnyThreadCountAndForPacketsAndSingleRays) {
  // Glass and metal (refraction: the eta scale), the throughput rule from the first bounce on.
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-glass-metal.json");
  scene["render"]["resolution"] = {40, 40};
  scene["render"]["russian_roulette"] = "throughput";
  scene["render"]["roulette_min_bounces"] = 0;
  const Scene s = test::loadSceneJson(dir, scene);
  const RenderScene rs(s);
  std::vector<SensorBuffer> buffers;
  std::vector<uint64_t> rays;
  for (int threads : {1, 2, 4})
    for (RayGrouping grouping : {RayGrouping::kPackets, RayGrouping::kSingleRays}) {
      SensorBuffer buffer;
      PathStats stats;
      tbb::task_arena arena{threads};
      arena.execute([&] { ASSERT_TRUE(renderUnit(rs, WorkUnit{2, 2 * 4, 4}, buffer, stats, nullptr, grouping)); });
      buffers.push_back(std::move(buffer));
      rays.push_back(stats.rays);
    }
  EXPECT_GT(*std::max_element(buffers[0].sums.begin(), buffers[0].sums.end()), 0.0);
  for (size_t k = 1; k < buffers.size(); ++k) {
    // Exact equality of every sum (no NaN reaches the sensor: NonFinite tests).
    EXPECT_TRUE(buffers[k].sums == buffers[0].sums) << "run " << k << " changed the bits";
    EXPECT_EQ(rays[k], rays[0]);
  }
}

TEST(Roulette, SceneFormatTakesTheBoolOrARuleAndNamesABadValue) {
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  EXPECT_EQ(test::loadSceneJson(dir, scene).render.roulette, kDefaultRoulette) << "a scene file without the field";
  const std::pair<json, RouletteRule> forms[] = {{false, RouletteRule::kOff},
                                                 {true, RouletteRule::kMax},
                                                 {"off", RouletteRule::kOff},
                                                 {"max", RouletteRule::kMax},
                                                 {"throughput", RouletteRule::kThroughput}};
  for (const auto& [value, rule] : forms) {
    scene["render"]["russian_roulette"] = value;
    EXPECT_EQ(test::loadSceneJson(dir, scene).render.roulette, rule) << value.dump();
  }
  scene["render"]["roulette_min_bounces"] = 4;
  EXPECT_EQ(test::loadSceneJson(dir, scene).render.rouletteMinBounces, 4);
  for (const json& bad : {json("sometimes"), json(1)}) {
    scene["render"]["russian_roulette"] = bad;
    try {
      test::loadSceneJson(dir, scene);
      ADD_FAILURE() << "accepted " << bad.dump();
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("russian_roulette"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace lensfarm
