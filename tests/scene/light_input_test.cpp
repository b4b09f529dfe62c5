// Bad light and environment input: every mistake is refused with one InputError naming the
// scene file and the exact field ("file: lights[1].cone_angle: ..."), and a missing or broken
// environment file is named with its path.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/film/image_io.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;
using test::kNoError;

class LightInputTest : public test::SceneErrorTest {
 protected:
  LightInputTest() : SceneErrorTest("bad-scene.json") {}

  // The minimal scene with `light` as lights[1].
  json withLight(const json& light) const {
    json scene = test::minimalSceneJson();
    scene["lights"].push_back(light);
    return scene;
  }
  // The message of loading the minimal scene with lights[1] = `base` changed by `edit`.
  template <typename Edit>
  std::string errorWith(json base, Edit edit) const {
    edit(base);
    return errorOf(withLight(base));
  }
};

class PointLightInput : public LightInputTest {};
class SpotLightInput : public LightInputTest {};
class DirectionalLightInput : public LightInputTest {};
class EnvironmentLightInput : public LightInputTest {
 protected:
  json withEnvironment(const json& environment) const {
    json scene = test::minimalSceneJson();
    scene["environment"] = environment;
    return scene;
  }
  void writeSky(const std::string& name, float value, int badX = -1, int badY = -1, int badChannel = 0) const {
    Image sky;
    sky.width = 16, sky.height = 8;
    sky.rgb.assign(16 * 8 * 3, value);
    if (badX >= 0) sky.rgb[3 * size_t(badY * 16 + badX) + size_t(badChannel)] = std::numeric_limits<float>::quiet_NaN();
    writeExr(dir_ / name, sky, ImageMetadata{});
  }
};

const json kPoint = {{"type", "point"}, {"position", {0, 0, -1}}, {"intensity", 2}};
const json kSpot = {
    {"type", "spot"}, {"position", {0, 0, -1}}, {"look_at", {0, 0, 0}}, {"intensity", 2}, {"cone_angle", 30}};
const json kSun = {{"type", "directional"}, {"direction", {0, 0, -1}}, {"irradiance", 1}};

TEST_F(PointLightInput, GoodLightsLoad) {
  EXPECT_EQ(errorOf(withLight(kPoint)), kNoError);
  EXPECT_EQ(errorOf(withLight(kSpot)), kNoError);
  EXPECT_EQ(errorWith(kSpot,
                      [](json& l) {
                        l.erase("look_at"), l["direction"] = {0, 0, 1}, l["falloff_start"] = 10;
                      }),
            kNoError);
  EXPECT_EQ(errorOf(withLight(kSun)), kNoError);
  EXPECT_EQ(errorWith(kSun, [](json& l) { l["angular_diameter"] = 0.53; }), kNoError);
}

TEST_F(PointLightInput, AnUnknownTypeListsTheKnownOnes) {
  EXPECT_TRUE(namesField(errorWith(kPoint, [](json& l) { l["type"] = "area"; }), "lights[1].type",
                         {"unknown light type \"area\"", "expected quad, point, spot or directional"}));
}

TEST_F(PointLightInput, EachBadFieldIsNamed) {
  EXPECT_TRUE(
      namesField(errorWith(kPoint, [](json& l) { l.erase("position"); }), "lights[1].position", {"is required"}));
  EXPECT_TRUE(namesField(errorWith(kPoint, [](json& l) { l["intensity"] = -1; }), "lights[1].intensity",
                         {"a colour is never negative"}));
  EXPECT_TRUE(namesField(errorWith(kPoint, [](json& l) { l["intensity"] = {1, 1e31, 1}; }), "lights[1].intensity[1]"));
  EXPECT_TRUE(namesField(errorWith(kPoint, [](json& l) { l["radius"] = 1; }), "lights[1].radius", {"unknown field"}));
  EXPECT_TRUE(namesField(errorWith(kPoint,
                                   [](json& l) {
                                     l["position"] = {0, 0, 2e18};
                                   }),
                         "lights[1].position", {"from the camera"}));
}

TEST_F(SpotLightInput, EachBadFieldIsNamed) {
  EXPECT_TRUE(namesField(errorWith(kSpot, [](json& l) { l["cone_angle"] = 0; }), "lights[1].cone_angle", {"(0, 90]"}));
  EXPECT_TRUE(namesField(errorWith(kSpot, [](json& l) { l["cone_angle"] = 95; }), "lights[1].cone_angle", {"[0, 90]"}));
  EXPECT_TRUE(namesField(errorWith(kSpot, [](json& l) { l["falloff_start"] = 31; }), "lights[1].falloff_start",
                         {"at most cone_angle (30 degrees)"}));
  EXPECT_TRUE(namesField(errorWith(kSpot,
                                   [](json& l) {
                                     l["direction"] = {0, 0, 1};
                                   }),
                         "lights[1].look_at", {"exactly one of look_at and direction"}));
  EXPECT_TRUE(namesField(errorWith(kSpot,
                                   [](json& l) {
                                     l["look_at"] = {0, 0, -1};
                                   }),
                         "lights[1].look_at", {"equals position"}));
  EXPECT_TRUE(namesField(errorWith(kSpot,
                                   [](json& l) {
                                     l.erase("look_at"), l["direction"] = {0, 0, 0};
                                   }),
                         "lights[1].direction", {"must not be [0, 0, 0]"}));
  EXPECT_TRUE(namesField(errorWith(kSpot, [](json& l) { l["intensity"] = -2; }), "lights[1].intensity"));
}

TEST_F(DirectionalLightInput, EachBadFieldIsNamed) {
  EXPECT_TRUE(namesField(errorWith(kSun,
                                   [](json& l) {
                                     l["direction"] = {0, 0, 0};
                                   }),
                         "lights[1].direction", {"must not be [0, 0, 0]"}));
  EXPECT_TRUE(
      namesField(errorWith(kSun, [](json& l) { l.erase("direction"); }), "lights[1].direction", {"is required"}));
  EXPECT_TRUE(namesField(errorWith(kSun, [](json& l) { l["irradiance"] = -0.5; }), "lights[1].irradiance"));
  EXPECT_TRUE(namesField(errorWith(kSun, [](json& l) { l["angular_diameter"] = 100; }), "lights[1].angular_diameter",
                         {"[0, 90]"}));
  EXPECT_TRUE(namesField(errorWith(kSun, [](json& l) { l["angular_diameter"] = 1e-9; }), "lights[1].angular_diameter",
                         {"must be 0 (a delta light) or in [1e-06, 90] degrees"}));
  // A tiny disk of a bright sun would carry a radiance the kernel cannot (scene-format.md).
  EXPECT_TRUE(namesField(errorWith(kSun, [](json& l) { l["irradiance"] = 1e30, l["angular_diameter"] = 0.01; }),
                         "lights[1].angular_diameter", {"above 1e30"}));
  EXPECT_TRUE(namesField(errorWith(kSun,
                                   [](json& l) {
                                     l["position"] = {0, 0, 1};
                                   }),
                         "lights[1].position", {"unknown field"}));
}

TEST_F(EnvironmentLightInput, GoodEnvironmentsLoad) {
  EXPECT_EQ(errorOf(withEnvironment({{"radiance", {0.1, 0.2, 0.3}}})), kNoError);
  writeSky("sky.exr", 0.5f);
  EXPECT_EQ(errorOf(withEnvironment({{"file", "sky.exr"}, {"strength", 3}, {"rotation", -90}})), kNoError);
}

TEST_F(EnvironmentLightInput, EachBadFieldIsNamed) {
  EXPECT_TRUE(namesField(errorOf(withEnvironment(json::object())), "environment.radiance",
                         {"give exactly one of radiance", "and file"}));
  writeSky("sky.exr", 0.5f);
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"radiance", 1}, {"file", "sky.exr"}})), "environment.radiance",
                         {"give exactly one of radiance"}));
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"radiance", -1}})), "environment.radiance", {"never negative"}));
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "sky.exr"}, {"strength", -1}})), "environment.strength"));
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "sky.exr"}, {"rotation", 400}})), "environment.rotation"));
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "sky.exr"}, {"exposure", 1}})), "environment.exposure",
                         {"unknown field"}));
  json notAnObject = test::minimalSceneJson();
  notAnObject["environment"] = "sky.exr";
  EXPECT_TRUE(namesField(errorOf(notAnObject), "environment", {"must be a JSON object"}));
  // A pixel times the strength beyond float.
  writeSky("bright.exr", 1e30f);
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "bright.exr"}, {"strength", 1e20}})), "environment.strength",
                         {"overflows"}));
}

TEST_F(EnvironmentLightInput, AMissingOrBrokenFileIsNamedWithItsPath) {
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "skies/nothere.exr"}})), "environment.file",
                         {"cannot read environment map", (dir_ / "skies/nothere.exr").string()}));
  dir_.write("notexr.exr", "this is not an image\n");
  EXPECT_TRUE(namesField(errorOf(withEnvironment({{"file", "notexr.exr"}})), "environment.file",
                         {(dir_ / "notexr.exr").string(), "is not a readable OpenEXR image"}));
  // The first bad pixel, named as EnvironmentMap::validate names it.
  writeSky("nan.exr", 0.5f, 12, 7, 0);
  const std::string message = errorOf(withEnvironment({{"file", "nan.exr"}}));
  EXPECT_EQ(message, sceneFile().string() + ": environment.file: pixel (12, 7) red is NaN");
}

}  // namespace
}  // namespace lensfarm
