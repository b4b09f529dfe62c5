// Light tracing beside the path tracer (render/light_tracer.h): the combined
// estimator agrees with the path tracer alone within noise, is the same bits
// for any thread count, lowers the variance of cornell-seed's caustic, and is
// chosen only where a scene calls for it.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "common/render/light_tracer.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/effects.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A diffuse floor and back wall, a mirror wall at x = -1 and a light 10 cm from
// it facing the floor: most of the floor's light near the mirror arrives light
// -> mirror -> floor.
json causticScene(const std::string& mirrorType, const json& camera) {
  json j = json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 0.2, -3], "look_at": [0, -0.3, 0], "up": [0, 1, 0],
                "sensor_width": 0.1, "focal_length": 0.07 },
    "materials": { "white": { "type": "lambertian", "albedo": 0.7 },
                   "red": { "type": "lambertian", "albedo": [0.7, 0.2, 0.2] },
                   "glass": { "type": "mirror", "reflectance": 0.9 } },
    "shapes": [ { "type": "quad", "corner": [-1, -1, -1], "edge1": [0, 0, 2.5], "edge2": [2, 0, 0], "material": "white" },
                { "type": "quad", "corner": [-1, -1, 1.5], "edge1": [2, 0, 0], "edge2": [0, 2, 0], "material": "red" },
                { "type": "quad", "corner": [-1, -1, -1], "edge1": [0, 2, 0], "edge2": [0, 0, 2.5], "material": "glass" } ],
    "lights": [ { "type": "quad", "corner": [-0.9, 0.5, -0.2], "edge1": [0.6, 0, 0], "edge2": [0, 0, 0.8],
                  "radiance": 8, "visible_to_camera": false } ],
    "render": { "resolution": [24, 24], "samples_per_pixel": 64, "max_bounces": 2, "seed": 7 }
  })");
  j["materials"]["glass"]["type"] = mirrorType;
  for (auto it = camera.begin(); it != camera.end(); ++it) j["camera"][it.key()] = it.value();
  return j;
}

Scene withMode(const test::TempDir& dir, json j, const std::string& mode, const std::string& name) {
  j["render"]["light_tracing"] = mode;
  return test::loadSceneJson(dir, j, name + "-" + mode + ".json");
}

// The combined estimator (light tracing on) against the path tracer alone: the
// project's test that two estimates are of one image (per-pixel z-test and
// image means).
void expectAgreement(const test::TempDir& dir, const json& j, const std::string& name, int renders = 16) {
  const Scene on = withMode(dir, j, "on", name), off = withMode(dir, j, "off", name);
  ASSERT_TRUE(RenderScene(on).lightTracing()) << name;
  ASSERT_FALSE(RenderScene(off).lightTracing()) << name;
  SCOPED_TRACE(name);
  test::expectSameImage(test::renderStatistics(on, renders), test::renderStatistics(off, renders));
}

TEST(LightTracer, AgreesWithThePathTracerThroughAMirror) {
  test::TempDir dir;
  expectAgreement(dir, causticScene("mirror", json::object()), "mirror-pinhole");
}

TEST(LightTracer, AgreesThroughARippledMirrorWithALensAndBladesWhenMirrorBouncesCount) {
  test::TempDir dir;
  json j =
      causticScene("rippled_mirror",
                   json{{"type", "thin_lens"}, {"f_number", 1.4}, {"focus_distance", 0.5}, {"aperture_blades", 6}});
  j["materials"]["glass"]["ripple"] = 0.1;
  j["render"]["mirror_bounces_count"] = true;
  j["render"]["max_bounces"] = 3;
  ASSERT_TRUE(RenderScene(withMode(dir, j, "on", "dof")).effects().depthOfField) << "the lens must be sampled";
  expectAgreement(dir, j, "rippled-lens-counted");
}

TEST(LightTracer, AgreesOnTheShippedScenesWithMirrorCaustics) {
  test::TempDir dir;
  std::vector<std::string> caustics;
  for (const auto& entry : std::filesystem::directory_iterator(test::scenesDir())) {
    if (entry.path().extension() != ".json") continue;
    const std::string name = entry.path().filename().string();
    json j = test::bundledSceneJson(name);
    if (j.contains("environment") && j["environment"].contains("file"))
      j["environment"]["file"] = (test::scenesDir() / j["environment"]["file"].get<std::string>()).string();
    j["render"]["resolution"] = {24, 24};
    j["render"]["samples_per_pixel"] = 64;
    j["render"].erase("samples_per_unit");
    j["render"].erase("tile_size");
    const Scene scene = test::loadSceneJson(dir, j, "auto.json");
    const RenderScene rs(scene);
    EXPECT_FALSE(rs.lightTracing()) << name << ": auto leaves it off (it does not pay, docs/performance.md)";
    if (!rs.effects().mirrorCaustics || !rs.camera().connects()) continue;
    caustics.push_back(name);
    expectAgreement(dir, j, name);
  }
  EXPECT_EQ(caustics, std::vector<std::string>{"cornell-seed.json"}) << "the seed is the one shipped thin-lens scene";
}

TEST(LightTracer, ForcedOnADiffuseSceneChangesNothingButAgrees) {
  test::TempDir dir;
  json j = test::bundledSceneJson("cornell-classic.json");
  j["render"]["resolution"] = {16, 16};
  j["render"]["samples_per_pixel"] = 4;
  expectAgreement(dir, j, "classic", 8);
}

TEST(LightTracer, SameBitsForAnyThreadCountAndUnitSplit) {
  test::TempDir dir;
  json j = test::bundledSceneJson("cornell-seed.json");
  j["render"]["resolution"] = {40, 40};
  j["render"]["samples_per_pixel"] = 4;
  j["render"]["samples_per_unit"] = 2;
  j["render"]["light_tracing"] = "on";
  j["render"]["light_tracing_ratio"] = 4.0;  // several chunks per unit
  const Scene scene = test::loadSceneJson(dir, j);
  const RenderScene rs(scene);
  ASSERT_TRUE(rs.lightTracing());
  ASSERT_GT(lightPathsOf(rs, 2), 2 * kChunkParticles);
  std::vector<std::vector<float>> images;
  for (int threads : {1, 2, 3}) images.push_back(test::renderScene(scene, threads).image.rgb);
  EXPECT_EQ(images[0], images[1]);
  EXPECT_EQ(images[0], images[2]);
  // The units of the job, rendered one by one into a sensor, are the job (what
  // a farm folds).
  Sensor sensor(40, 40);
  PathStats stats;
  for (uint64_t u : {0u, 1u}) {
    SensorBuffer b;
    ASSERT_TRUE(renderUnit(rs, unitAt(u, 4, 2), b, stats));
    sensor.add(b);
  }
  EXPECT_EQ(sensor.developImage().rgb, images[0]);
  // A tile of a job with light tracing is refused, not silently wrong.
  WorkUnit tile = unitAt(0, 4, 2);
  tile.region = PixelRegion{0, 0, 8, 8};
  SensorBuffer b;
  EXPECT_THROW(renderUnit(rs, tile, b, stats), std::invalid_argument);
}

// The 2013 report's caustic: at equal samples, the variance of the pixels the light
// tracer touches (the floor and walls lit through the rippled mirror; elsewhere
// both estimators trace the same camera paths with the same numbers) is lower
// with light tracing: a figure, printed.
TEST(LightTracer, LowersTheVarianceOfTheSeedCaustic) {
  test::TempDir dir;
  json j = test::bundledSceneJson("cornell-seed.json");
  j["render"]["resolution"] = {32, 32};
  j["render"]["samples_per_pixel"] = 16;
  j["render"]["light_tracing_ratio"] = 1.0;  // (0.25, the default: 1.03; 4: 1.29)
  const auto on = test::renderStatistics(withMode(dir, j, "on", "seed"), 16);
  const auto off = test::renderStatistics(withMode(dir, j, "off", "seed"), 16);
  double vOn = 0, vOff = 0, allOn = 0, allOff = 0;
  size_t touched = 0;
  for (size_t k = 0; k < off.variance.size(); ++k) {
    allOn += on.variance[k], allOff += off.variance[k];
    if (on.mean[k] == off.mean[k]) continue;
    vOn += on.variance[k], vOff += off.variance[k];
    ++touched;
  }
  std::printf(
      "seed caustic, 32x32, 16 spp, 1 light path per camera path, 16 "
      "renders: variance off / on %.2f "
      "over the %zu pixel-channels light tracing "
      "touches, %.2f over the image\n",
      vOff / vOn, touched, allOff / allOn);
  EXPECT_GT(touched, off.variance.size() / 4);
  EXPECT_GT(vOff / vOn, 1.15);
}

TEST(LightTracer, TheAnalysisFindsTheCausticAndTheSettingForcesIt) {
  test::TempDir dir;
  const auto decide = [&](json j) { return RenderScene(test::loadSceneJson(dir, j)).lightTracing(); };
  json seed = test::bundledSceneJson("cornell-seed.json");
  EXPECT_FALSE(decide(seed)) << "auto: the caustic is found, but binary weights do not pay";
  EXPECT_TRUE(RenderScene(test::loadSceneJson(dir, seed)).effects().mirrorCaustics);
  EXPECT_FALSE(
      RenderScene(test::loadSceneJson(dir, test::bundledSceneJson("cornell-classic.json"))).effects().mirrorCaustics);
  seed["render"]["light_tracing"] = "on";
  EXPECT_TRUE(decide(seed));
  json classic = test::bundledSceneJson("cornell-classic.json");
  EXPECT_FALSE(decide(classic)) << "no mirror: off and free";
  classic["render"]["light_tracing"] = "on";
  EXPECT_TRUE(decide(classic));
  json tiled = seed;
  tiled["render"]["tile_size"] = 64;
  EXPECT_FALSE(decide(tiled)) << "tiled units render a region only";
  json naive = seed;
  naive["render"]["integrator"] = "naive";
  EXPECT_FALSE(decide(naive));
  json off = seed;
  off["render"]["light_tracing"] = "off";
  EXPECT_FALSE(decide(off));
  json real = test::bundledSceneJson("cornell-real-lens.json");
  real["render"]["light_tracing"] = "on";
  EXPECT_FALSE(decide(real)) << "a real lens cannot be connected to";
  json bad = seed;
  bad["render"]["light_tracing"] = "sometimes";
  EXPECT_THROW(
      {
        try {
          test::loadSceneJson(dir, bad);
        } catch (const std::exception& e) {
          EXPECT_NE(std::string(e.what()).find("render.light_tracing"), std::string::npos) << e.what();
          throw;
        }
      },
      std::exception);
}

}  // namespace
}  // namespace lensfarm
