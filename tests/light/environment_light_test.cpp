// The environment as a light, end to end: seen directly, lighting a convex white object (a
// furnace with one bounce: the answer is albedo x L exactly), an OpenEXR sky whose pixels the
// camera sees where the convention of light/environment_map.h puts them (rotation included), and
// the file read as an asset (hashed, listed among the effects).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/film/image_io.h"
#include "common/scene/effects.h"
#include "common/util/error.h"
#include "tests/light/light_test_support.h"
#include "tests/test_support.h"
#include "tests/texture/test_images.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A pinhole at the origin looking along `view` (up +y, at most 30 degrees from the horizon) over
// a scene with nothing in view: one small triangle far below (a scene needs a triangle) and the
// environment given.
json skyScene(const json& environment, const json& view, double angleOfView, int resolution) {
  json scene = json::parse(R"({
    "format": "lensfarm-scene/1",
    "materials": { "grey": { "type": "lambertian", "albedo": 0.5 } },
    "shapes": [ { "type": "triangles", "material": "grey", "vertices": [[0, -1000, 0], [1, -1000, 0], [0, -1000, 1]] } ],
    "render": { "samples_per_pixel": 4, "max_bounces": 3, "seed": 1 }
  })");
  scene["camera"] = {{"type", "pinhole"}, {"position", {0, 0, 0}}, {"look_at", view}, {"angle_of_view", angleOfView}};
  scene["environment"] = environment;
  scene["render"]["resolution"] = {resolution, resolution};
  return scene;
}

TEST(EnvironmentLight, SeenDirectlyItIsExactlyItsRadiance) {
  const Spectrum l(0.5f, 1.0f, 2.0f);
  for (const char* integrator : {"nee_mis", "nee", "naive"})
    for (int bounces : {0, 3}) {
      SCOPED_TRACE(std::string(integrator) + " B = " + std::to_string(bounces));
      json scene = skyScene({{"radiance", {0.5, 1, 2}}}, {0, 0.3, 1}, 60, 8);
      scene["render"]["integrator"] = integrator;
      scene["render"]["max_bounces"] = bounces;
      test::TempDir dir;
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      for (size_t k = 0; k < r.image.rgb.size(); ++k) ASSERT_EQ(r.image.rgb[k], l[int(k % 3)]);
      EXPECT_EQ(r.stats.lightHits, r.stats.paths);
    }
}

TEST(EnvironmentLight, AConvexWhiteObjectInAUniformEnvironmentIsAlbedoTimesItsRadiance) {
  // Every point of a convex object sees the environment over its whole hemisphere and nothing
  // else, at every bounce: it leaves a L, whatever B >= 1. The camera sees only the sphere.
  const double a = 0.7, l = 2.0;
  test::TempDir dir;
  dir.write("sphere.obj", test::sphereObj(16, 32));
  json scene = json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 0, -3], "look_at": [0, 0, 0], "angle_of_view": 25 },
    "materials": { "white": { "type": "lambertian", "albedo": 0.7 } },
    "shapes": [ { "type": "obj", "file": "sphere.obj", "material": "white" } ],
    "environment": { "radiance": 2 },
    "render": { "resolution": [16, 16], "samples_per_pixel": 64, "seed": 2 }
  })");
  for (const char* integrator : {"naive", "nee", "nee_mis"})
    for (int bounces : {1, 3}) {
      SCOPED_TRACE(std::string(integrator) + " B = " + std::to_string(bounces));
      scene["render"]["integrator"] = integrator;
      scene["render"]["max_bounces"] = bounces;
      const Scene loaded = test::loadSceneJson(dir, scene);
      const RenderScene rs(loaded);
      const std::vector<DVec3> means = test::cellMeans(rs);
      double mean = 0.0;
      for (const DVec3& m : means) mean += m.g / double(means.size());
      if (std::string(integrator) == "naive") {
        // Each cosine-sampled direction carries a and escapes to L: every sample is a L.
        for (const DVec3& m : means) ASSERT_NEAR(m.g, a * l, 1e-6);
      } else {
        // Light samples are uniform over the sphere of directions (half of them below the surface).
        EXPECT_NEAR(mean, a * l, 0.01 * a * l);
      }
    }
}

// A 4 x 2 sky, every pixel its own colour: pixel (i, j) is (i + 1, j + 1, 10 i + j + 1).
Spectrum skyPixel(int i, int j) { return Spectrum(float(i + 1), float(j + 1), float(10 * i + j + 1)); }

TEST(EnvironmentLight, CameraRaysSeeTheSkyImagesPixelsWhereTheConventionPutsThem) {
  // light/environment_map.h: u = 0.5 + phi / 2 pi along a row, phi = atan2(x, -z); v = theta / pi
  // down the image. A camera at the origin looking along -z (up +y, so its right is +x) with a
  // 60-degree view sees phi in [-30, 30] and theta in [60, 120] degrees: columns 1 (left of -z,
  // towards -x) and 2 (right, towards +x), row 0 (above the horizon) and 1 (below). The written
  // image has up at the top and right to the right (scene-format.md, "Lens flip").
  test::TempDir dir;
  Image sky;
  sky.width = 4, sky.height = 2;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) sky.rgb.push_back(skyPixel(i, j)[c]);
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  // Rotation 90 turns the sky counter-clockwise seen from above: what was along -z is along -x.
  for (const auto& [rotation, view] : std::vector<std::pair<double, json>>{{0.0, {0, 0, -1}}, {90.0, {-1, 0, 0}}}) {
    SCOPED_TRACE(rotation);
    json scene = skyScene({{"file", "sky.exr"}, {"rotation", rotation}}, view, 60, 8);
    scene["render"]["max_bounces"] = 0;
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const Spectrum want = skyPixel(x < 4 ? 1 : 2, y < 4 ? 0 : 1);
        ASSERT_EQ(r.image.at(x, y), want) << "image pixel " << x << ", " << y;
      }
  }
}

TEST(EnvironmentLight, ARadianceHdrSkyIsSeenWhereAnExrSkyIs) {
  // The same 4 x 2 sky as a Radiance HDR (RGBE: values that are powers of two times 8-bit
  // mantissas survive exactly) and as an EXR: the camera sees the same pixels.
  test::TempDir dir;
  Image sky;
  sky.width = 4, sky.height = 2;
  std::vector<float> hdrPixels;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) {
        const float v = std::ldexp(float(1 + i + 4 * j + c), -2);
        sky.rgb.push_back(v);
        hdrPixels.push_back(v);
      }
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  std::ofstream(dir / "sky.hdr", std::ios::binary) << test::hdr(4, 2, 3, hdrPixels);
  std::vector<Image> seen;
  for (const char* file : {"sky.exr", "sky.hdr"}) {
    json scene = skyScene({{"file", file}}, {0, 0, -1}, 60, 8);
    scene["render"]["max_bounces"] = 0;
    seen.push_back(test::renderScene(test::loadSceneJson(dir, scene)).image);
  }
  ASSERT_EQ(seen[0].rgb.size(), seen[1].rgb.size());
  for (size_t k = 0; k < seen[0].rgb.size(); ++k) ASSERT_EQ(seen[0].rgb[k], seen[1].rgb[k]) << k;
  // Neither: named as such.
  std::ofstream(dir / "sky.png", std::ios::binary) << "GIF89a....";
  EXPECT_THROW(test::loadSceneJson(dir, skyScene({{"file", "sky.png"}}, {0, 0, -1}, 60, 8)), InputError);
}

TEST(EnvironmentLight, TheSkyFileIsAnAssetOfTheSceneAndIsListedAmongTheEffects) {
  test::TempDir dir;
  Image sky;
  sky.width = 64, sky.height = 32;
  sky.rgb.assign(64 * 32 * 3, 0.25f);
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  const json scene = skyScene({{"file", "sky.exr"}, {"strength", 2}}, {0, 0, 1}, 40, 4);
  const Scene a = test::loadSceneJson(dir, scene);
  ASSERT_EQ(a.assets.count("sky.exr"), 1u);
  const EffectSet effects = analyzeEffects(a, a.camera());
  EXPECT_NE(effects.summary().find("environment: on (sky.exr 64x32)"), std::string::npos) << effects.summary();
  EXPECT_NE(effects.summary().find("lights seen by the camera: on"), std::string::npos) << effects.summary();
  // Another sky is another scene.
  sky.rgb[7] = 0.5f;
  writeExr(dir / "sky.exr", sky, ImageMetadata{});
  const Scene b = test::loadSceneJson(dir, scene);
  EXPECT_NE(a.hash, b.hash);
  EXPECT_NE(a.assets.at("sky.exr"), b.assets.at("sky.exr"));
  // Seen directly: the pixels times the strength.
  const test::Rendered r = test::renderScene(a);
  for (float v : r.image.rgb) ASSERT_EQ(v, 0.5f);
  // A scene without such lights has none to pay for at every miss.
  const Scene none = test::loadSceneJson(dir, test::bundledSceneJson("cornell-classic.json"), "classic.json");
  EXPECT_FALSE(RenderScene(none).hasEscapeLights());
  EXPECT_TRUE(RenderScene(a).hasEscapeLights());
}

}  // namespace
}  // namespace lensfarm
