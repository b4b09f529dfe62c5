// Every kind of light at once (a quad, a point, a spot, a sun with and one without an angular
// diameter, an OpenEXR environment): the three estimators, which reach the lights in different
// ways (naive: scattered rays, and light samples of the delta lights alone; nee: light samples;
// nee_mis: both, weighed by the power heuristic), estimate the same image.
#include <gtest/gtest.h>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A floor with a wall and a block under every kind of light; `dir` receives the sky's EXR.
json everyLightScene(const test::TempDir& dir) {
  Image sky;  // brighter towards the zenith, a warm band at the horizon
  sky.width = 16, sky.height = 8;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 16; ++i) {
      const float up = float(8 - j) / 8.0f;
      sky.rgb.insert(sky.rgb.end(), {0.2f * up + (j == 4 ? 0.6f : 0.0f), 0.3f * up, 0.6f * up + 0.05f * float(i % 4)});
    }
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  return json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 2.5, -4], "look_at": [0, 0.3, 0], "angle_of_view": 55 },
    "materials": { "grey": { "type": "lambertian", "albedo": 0.6 },
                   "red": { "type": "lambertian", "albedo": [0.7, 0.2, 0.1] } },
    "shapes": [
      { "type": "quad", "material": "grey", "corner": [-3, 0, -3], "edge1": [0, 0, 6], "edge2": [6, 0, 0] },
      { "type": "quad", "material": "red", "corner": [-3, 0, 2], "edge1": [0, 2, 0], "edge2": [6, 0, 0] },
      { "type": "quad", "material": "grey", "corner": [-0.5, 0.8, -0.5], "edge1": [1, 0, 0], "edge2": [0, 0, 1] },
      { "type": "quad", "material": "grey", "corner": [-0.5, 0, -0.5], "edge1": [0, 0.8, 0], "edge2": [1, 0, 0] }
    ],
    "lights": [
      { "type": "quad", "corner": [1, 2.5, -1], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "radiance": 4 },
      { "type": "point", "position": [-1.5, 1.5, -1], "intensity": [3, 2.5, 2] },
      { "type": "spot", "position": [1.5, 2, 1], "look_at": [0, 0, 0], "intensity": 8, "cone_angle": 35, "falloff_start": 25 },
      { "type": "directional", "direction": [-1, 2, -1], "irradiance": 0.4 },
      { "type": "directional", "direction": [1, 1, -0.5], "irradiance": 0.8, "angular_diameter": 30 }
    ],
    "environment": { "file": "sky.exr", "strength": 1.5, "rotation": 30 },
    "render": { "resolution": [16, 12], "samples_per_pixel": 16, "max_bounces": 3 }
  })");
}

TEST(LightSelection, EveryEstimatorAgreesOnASceneWithEveryKindOfLight) {
  test::TempDir dir;
  json scene = everyLightScene(dir);
  scene["render"]["integrator"] = "nee_mis";
  const test::ImageStatistics misStats = test::renderStatistics(test::loadSceneJson(dir, scene, "mis.json"), 16);
  EXPECT_GT(misStats.imageMean, 0.05);
  for (const char* integrator : {"nee", "naive"}) {
    SCOPED_TRACE(integrator);
    scene["render"]["integrator"] = integrator;
    scene["render"]["samples_per_pixel"] = std::string(integrator) == "naive" ? 64 : 16;
    const test::ImageStatistics other = test::renderStatistics(test::loadSceneJson(dir, scene, "other.json"), 16);
    test::expectSameImage(misStats, other);
  }
}

}  // namespace
}  // namespace lensfarm
