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
#include <numbers>

#include "common/render/light_tracer.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/effects.h"
#include "tests/support/placement.h"
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

// A diffuse floor (albedo 0.5) under a glass slab (index 1.5, 0.2 thick, 2 x 2, its underside 1
// above the floor), every length times `scale` and moved by `offset`, lit from straight above by a
// sun without diameter (E = 1), a point light 3 above the floor or one inside the slab, 0.1 above
// its underside (I = 9 scale^2), seen from the side under the slab. Only light paths reach the
// floor under the slab (no ray reaches a delta light). Paraxially, under the slab's centre: the
// slab passes T^2 / (1 - R^2) of the light at normal incidence, R = ((n - 1) / (n + 1))^2, T = 1 - R;
// it moves a point light's image towards the floor by t (1 - 1/n), so E = I T^2 / (1 - R^2) /
// (3 - 0.2 / 3)^2; and a point inside glass, leaving it, lights the floor 1 below as one at the
// distance n 1 + g, g the path in glass (a beam's angles grow n-fold as it leaves), over each path
// with k reflections inside: E = I T sum_k R^k / (n + 0.1 + 0.2 k)^2. The floor's radiance is
// (0.5 / pi) E.
json slabScene(const std::string& light, double scale, const glm::dvec3& offset) {
  const test::PlacedPoint at{scale, offset};
  const test::ScaledVector v{scale};
  json j = json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "up": [0, 1, 0], "sensor_width": 0.01, "focal_length": 0.05 },
    "materials": { "floor": { "type": "lambertian", "albedo": 0.5 },
                   "glass": { "type": "dielectric", "ior": 1.5 } },
    "render": { "resolution": [16, 16], "samples_per_pixel": 64, "max_bounces": 1, "seed": 3,
                "light_tracing_ratio": 16 }
  })");
  j["camera"]["sensor_width"] = 0.01 * scale;  // camera lengths are in the scene's unit
  j["camera"]["focal_length"] = 0.05 * scale;
  j["camera"]["position"] = at(0, 0.5, -3);
  j["camera"]["look_at"] = at(0, 0, 0);
  const auto quad = [&](json corner, json e1, json e2, const char* material) {
    j["shapes"].push_back({{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", material}});
  };
  quad(at(-4, 0, -4), v(0, 0, 8), v(8, 0, 0), "floor");
  // The slab's six faces, normals outwards (edge1 x edge2).
  const double x0 = -1, x1 = 1, y0 = 1, y1 = 1.2, z0 = -1, z1 = 1;
  quad(at(x0, y1, z0), v(0, 0, z1 - z0), v(x1 - x0, 0, 0), "glass");
  quad(at(x0, y0, z0), v(x1 - x0, 0, 0), v(0, 0, z1 - z0), "glass");
  quad(at(x1, y0, z0), v(0, y1 - y0, 0), v(0, 0, z1 - z0), "glass");
  quad(at(x0, y0, z0), v(0, 0, z1 - z0), v(0, y1 - y0, 0), "glass");
  quad(at(x0, y0, z1), v(x1 - x0, 0, 0), v(0, y1 - y0, 0), "glass");
  quad(at(x0, y0, z0), v(0, y1 - y0, 0), v(x1 - x0, 0, 0), "glass");
  if (light == "sun")
    j["lights"] = json::array({{{"type", "directional"}, {"direction", {0, 1, 0}}, {"irradiance", 1.0}}});
  else
    j["lights"] = json::array({{{"type", "point"},
                                {"position", light == "inside" ? at(0, 1.1, 0) : at(0, 3, 0)},
                                {"intensity", 9.0 * scale * scale}}});
  return j;
}

// A shipped scene at side x side pixels and spp samples per pixel.
json bundledAt(const std::string& name, int side, int spp) {
  json j = test::bundledSceneJson(name);
  j["render"]["resolution"] = {side, side};
  j["render"]["samples_per_pixel"] = spp;
  return j;
}

Scene withMode(const test::TempDir& dir, json j, const std::string& mode, const std::string& name) {
  j["render"]["light_tracing"] = mode;
  j["render"]["path_guiding"] = "off";  // light paths against the path tracer alone
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

TEST(LightTracer, AgreesOnTheShippedScenesWithCaustics) {
  test::TempDir dir;
  std::vector<std::string> caustics;
  for (const auto& entry : std::filesystem::directory_iterator(test::scenesDir())) {
    if (entry.path().extension() != ".json") continue;
    const std::string name = entry.path().filename().string();
    json j = test::bundledSceneJson(name);
    // An environment map's sun seen through glass is a caustic the path tracer alone finds too
    // rarely for a per-pixel test at these samples (it is what light paths are for): the
    // agreement is judged under a sky of the map's mean radiance, where both converge.
    if (j.contains("environment") && j["environment"].contains("file"))
      j["environment"] = {{"radiance", {0.9, 1.0, 1.2}}};
    j["render"]["resolution"] = {24, 24};
    j["render"]["samples_per_pixel"] = 64;
    j["render"].erase("samples_per_unit");
    j["render"].erase("tile_size");
    const Scene scene = test::loadSceneJson(dir, j, "auto.json");
    const RenderScene rs(scene);
    // Auto traces light paths where glass or a mirror shows a diffuse surface a light that is not
    // an emitting surface (glass-metal-sky's sky and sun through the glass ball); for emitting
    // surfaces it does not pay (docs/performance.md).
    EXPECT_EQ(rs.lightTracing(), name == "glass-metal-sky.json") << name;
    EXPECT_FALSE(rs.lightTracesTriangles()) << name;
    if (!(rs.effects().mirrorCaustics || rs.lightTracing()) || !rs.camera().connects()) continue;
    caustics.push_back(name);
    expectAgreement(dir, j, name);
  }
  std::sort(caustics.begin(), caustics.end());
  EXPECT_EQ(caustics, (std::vector<std::string>{"cornell-seed.json", "glass-metal-sky.json"}))
      << "the shipped thin-lens scenes with caustics";
}

// A sun with a diameter (a disk of radiance, reached by scattered rays as well as light samples)
// seen through glass: light paths from it against the path tracer alone, per pixel.
TEST(LightTracer, AgreesThroughGlassUnderASunWithADiameter) {
  test::TempDir dir;
  json j = slabScene("sun", 1.0, glm::dvec3(0.0));
  j["lights"][0]["angular_diameter"] = 40;
  j["lights"][0]["direction"] = {0.2, 1, 0.1};
  j["render"]["max_bounces"] = 2;
  j["render"]["light_tracing_ratio"] = 1;
  expectAgreement(dir, j, "sun-disk-slab");
}

// Particles from an emitting quad aimed by a cone at the glass ball (render/light_emission.h),
// forced on: the caustic under the ball and everything else as the path tracer alone has it.
TEST(LightTracer, AgreesThroughGlassWithParticlesAimedFromAnAreaLight) {
  test::TempDir dir;
  json j = bundledAt("cornell-glass.json", 24, 64);
  j["render"]["max_bounces"] = 3;
  j["render"]["light_tracing_ratio"] = 1;
  // A light as wide as the ceiling: its image in the ball, which the ceiling and walls see lit
  // through it, is then large enough for the path tracer alone to converge per pixel at these
  // samples. With the shipped 0.5 x 0.5 light it finds the ceiling's caustic (the light seen
  // through the ball) too rarely: summed over the ceiling near the light, its mean rises with the
  // samples towards the light paths' (2.69, 2.76, 2.81 at 64, 1024, 8192 spp, 8 renders each,
  // against 2.81-2.82), a heavy tail the per-pixel test cannot judge at 64.
  j["lights"][0]["corner"] = {-0.9, -0.99, -0.9};
  j["lights"][0]["edge1"] = {0, 0, 1.8};
  j["lights"][0]["edge2"] = {1.8, 0, 0};
  const RenderScene rs(withMode(dir, j, "on", "aimed"));
  ASSERT_TRUE(rs.lightTracesTriangles());
  const Vec3 towardsTarget = rs.particleTarget().center - rs.lights().triangleLights()[0].v0;
  ASSERT_GT(glm::length(towardsTarget), rs.particleTarget().radius) << "the light lies outside the target: a cone";
  expectAgreement(dir, j, "cornell-glass-aimed");
  // A lamp off to the side of the glass slab, facing down: the floor under the slab is lit only
  // through it, by particles leaving the lamp some 40 degrees from its normal (its cosine there
  // matters: leaving it out fails this).
  json slab = slabScene("sun", 1.0, glm::dvec3(0.0));
  slab["lights"] = json::array(
      {{{"type", "quad"}, {"corner", {2, 3, -0.5}}, {"edge1", {1, 0, 0}}, {"edge2", {0, 0, 1}}, {"radiance", 10.0}}});
  slab["render"]["light_tracing_ratio"] = 1;
  slab["render"]["samples_per_pixel"] = 512;  // the path tracer finds the lamp through the slab ~1 % of the time
  expectAgreement(dir, slab, "slab-under-a-lamp");
}

TEST(LightTracer, ForcedOnADiffuseSceneChangesNothingButAgrees) {
  test::TempDir dir;
  expectAgreement(dir, bundledAt("cornell-classic.json", 16, 4), "classic", 8);
}

// Light paths from an emitting surface (cornell-seed, forced on) and from the environment
// (glass-metal-sky, auto): the same bits for 1, 2 and 3 threads and unit by unit.
TEST(LightTracer, SameBitsForAnyThreadCountAndUnitSplit) {
  test::TempDir dir;
  for (const std::string name : {"cornell-seed.json", "glass-metal-sky.json"}) {
    SCOPED_TRACE(name);
    json j = bundledAt(name, 40, 4);
    if (j.contains("environment"))
      j["environment"]["file"] = (test::scenesDir() / j["environment"]["file"].get<std::string>()).string();
    j["render"]["samples_per_unit"] = 2;
    if (name == "cornell-seed.json") j["render"]["light_tracing"] = "on";
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
  // The environment's sun through glass: auto turns it on, for the sky's particles alone.
  json sky = test::bundledSceneJson("glass-metal-sky.json");
  sky["environment"] = {{"radiance", 1.0}};
  const RenderScene outdoors(test::loadSceneJson(dir, sky));
  EXPECT_TRUE(outdoors.lightTracing());
  EXPECT_FALSE(outdoors.lightTracesTriangles());
  EXPECT_NE(outdoors.effects().summary().find("light tracing: on (0.25 light path(s) per camera path from environment"),
            std::string::npos)
      << outdoors.effects().summary();
  sky["render"]["adaptive"] = true;
  EXPECT_FALSE(decide(sky)) << "adaptive sampling gives blocks their own sample counts";
  // Glass under an emitting quad: particles from triangles do not pay with binary weights.
  EXPECT_FALSE(decide(test::bundledSceneJson("cornell-glass.json")));
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

// The hard case of the class: a delta light's caustic through glass, which only light paths
// reach, against the slab's Fresnel transmission and focal shift, at the origin, a million away
// and at 1e-4 and 1e4 scale.
TEST(LightTracer, ADeltaLightThroughAGlassSlabLightsTheFloorAsFresnelAndTheSlabsShiftSay) {
  test::TempDir dir;
  const double n = 1.5, r = (n - 1) * (n - 1) / ((n + 1) * (n + 1)), t = 1 - r;
  const double slab = t * t / (1 - r * r), floorRadiance = 0.5 / std::numbers::pi;
  struct Case {
    std::string light;
    double scale;
    glm::dvec3 offset;
  };
  const std::vector<Case> cases = {{"sun", 1, {0, 0, 0}},        {"point", 1, {0, 0, 0}},      {"inside", 1, {0, 0, 0}},
                                   {"sun", 1, {1e6, -1e6, 1e6}}, {"point", 1, {1e6, 0, -1e6}}, {"sun", 1e-4, {0, 0, 0}},
                                   {"point", 1e4, {3e5, 0, 0}},  {"inside", 1e-4, {0, 1e2, 0}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.light + " at scale " + std::to_string(c.scale) + ", offset " + std::to_string(c.offset.x));
    json j = slabScene(c.light, c.scale, c.offset);
    const Scene auto_ = test::loadSceneJson(dir, j, "slab-auto.json");
    const RenderScene rs(auto_);
    ASSERT_TRUE(rs.lightTracing()) << rs.effects().summary();
    EXPECT_NE(rs.effects().summary().find("no camera path reaches them"), std::string::npos) << rs.effects().summary();
    double e = c.light == "sun" ? slab : slab * 9.0 / ((3 - 0.2 * (1 - 1 / n)) * (3 - 0.2 * (1 - 1 / n)));
    if (c.light == "inside") {
      e = 0.0;
      for (int k = 0; k < 8; ++k) e += 9.0 * t * std::pow(r, k) / ((n + 0.1 + 0.2 * k) * (n + 0.1 + 0.2 * k));
    }
    const double expected = floorRadiance * e;
    const int renders = 2;
    const auto stats = test::renderStatistics(auto_, renders);
    // The 2 x 2 pixels at the centre see the floor within 0.1 of the point under the slab's centre.
    double mean = 0.0, variance = 0.0;
    for (int y : {7, 8})
      for (int x : {7, 8})
        for (int ch = 0; ch < 3; ++ch) {
          const size_t k = 3 * (size_t(y) * 16 + size_t(x)) + size_t(ch);
          mean += stats.mean[k] / 12.0, variance += stats.variance[k] / (144.0 * renders);
        }
    std::printf("%s scale %g: floor under the slab %.5f, expected %.5f (sigma %.5f)\n", c.light.c_str(), c.scale, mean,
                expected, std::sqrt(variance));
    EXPECT_NEAR(mean, expected, 4.0 * std::sqrt(variance) + 0.01 * expected) << "sigma " << std::sqrt(variance);
    // Where light paths cannot run (adaptive sampling), the render warns that the caustic is lost.
    json adaptive = j;
    adaptive["render"]["adaptive"] = true;
    const auto warnings = RenderScene(test::loadSceneJson(dir, adaptive, "slab-adaptive.json")).effects().warnings();
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("are black without light paths"), std::string::npos) << warnings[0];
    // Without light paths the floor under the slab is black: the caustic is the light tracer's.
    j["render"]["light_tracing"] = "off";
    const auto off = test::renderScene(test::loadSceneJson(dir, j, "slab-off.json"), 2).image.rgb;
    EXPECT_EQ(off[3 * (7 * 16 + 7)], 0.0f);
  }
}

}  // namespace
}  // namespace lensfarm
