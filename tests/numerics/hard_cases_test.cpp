// The cases that break renderers: deep furnaces, extreme apertures, scale, degenerate geometry,
// grazing views of a lit plane.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/camera/depth_of_field.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

json seedScene(int size, uint64_t spp) {
  json scene = test::bundledSceneJson("cornell-seed.json");
  scene["render"]["resolution"] = {size, size};
  scene["render"]["samples_per_pixel"] = spp;
  // The same random numbers must trace the same paths up to rounding: path guiding's learned field
  // turns rounding into other paths (its images agree within noise at any scale and place:
  // PathGuiding.AgreesFarFromTheOriginAndAtExtremeScales).
  scene["render"]["path_guiding"] = "off";
  return scene;
}

void expectSane(const test::Rendered& r, const std::string& what) {
  double sum = 0;
  for (float v : r.image.rgb) {
    ASSERT_TRUE(std::isfinite(v)) << what;
    ASSERT_GE(v, 0.0f) << what;
    sum += v;
  }
  EXPECT_GT(sum, 0.0) << what << ": a black image";
  EXPECT_EQ(r.stats.dropped, 0u) << what;
}

TEST(Furnace, StaysWithinOnePercentUpTo64Bounces) {
  for (double a : {0.5, 0.8}) {
    for (const char* integrator : {"naive", "nee_mis"}) {
      test::TempDir dir;
      json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", a}, {"emission", 1.0}}, 16, 32, 64);
      scene["render"]["integrator"] = integrator;
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      const double expected = (1.0 - std::pow(a, 65)) / (1.0 - a);  // 1 + a + ... + a^64
      EXPECT_NEAR(r.mean[1], expected, 0.01 * expected) << integrator << " albedo " << a;
    }
  }
}

TEST(Lens, EveryFNumberFromOneToAMillionAndInfinityRendersSanely) {
  for (const json& n : {json(1), json(2), json(16), json(1000), json(1e6), json("infinity")}) {
    test::TempDir dir;
    json scene = seedScene(24, 8);
    scene["camera"]["f_number"] = n;
    expectSane(test::renderScene(test::loadSceneJson(dir, scene)), "N = " + n.dump());
  }
}

TEST(Lens, AClosingApertureConvergesToThePinholeImage) {
  // Same random numbers, so as R -> 0 every path approaches the pinhole's: the difference must
  // shrink with R and vanish in the limit.
  test::TempDir dir;
  json scene = seedScene(32, 8);
  scene["camera"]["f_number"] = "infinity";
  const test::Rendered pinhole = test::renderScene(test::loadSceneJson(dir, scene, "pinhole.json"));
  double previous = 1e30;
  for (double n : {16.0, 1e3, 1e6}) {
    scene["camera"]["f_number"] = n;
    const test::Rendered lens = test::renderScene(test::loadSceneJson(dir, scene, "lens.json"));
    double diff = 0, total = 0;
    for (size_t k = 0; k < lens.image.rgb.size(); ++k) {
      diff += std::abs(double(lens.image.rgb[k]) - pinhole.image.rgb[k]);
      total += pinhole.image.rgb[k];
    }
    const double relative = diff / total;
    EXPECT_LE(relative, previous) << "N = " << n;
    previous = relative;
    if (n == 1e6) {
      EXPECT_LT(relative, 1e-3) << "N = 1e6 is a pinhole in all but name";
    }
  }
}

TEST(Lens, FarLimitIsInfiniteForSubjectsAtOrBeyondTheHyperfocalDistance) {
  const double f = 0.095, c = circleOfConfusion(0.1, 0.1);
  for (double n : {32.0, 1e6}) {
    const double h = f * f / (n * c) + f;
    for (double s1 : {h, 2 * h, 100 * h}) {
      if (s1 <= f) continue;
      EXPECT_TRUE(std::isinf(textbookDepthOfField(f, s1, n, c).farLimit)) << "N " << n << " S1 " << s1;
    }
  }
}

// Multiplies every length of cornell-seed by k: camera, lens, box and light.
json scaled(json scene, double k) {
  auto times = [k](json& v) {
    for (auto& x : v) x = x.get<double>() * k;
  };
  json& cam = scene["camera"];
  times(cam["position"]);
  times(cam["look_at"]);
  cam["sensor_width"] = cam["sensor_width"].get<double>() * k;
  cam["focal_length"] = cam["focal_length"].get<double>() * k;
  cam["focus_distance"] = cam["focus_distance"].get<double>() * k;
  json& t = scene["shapes"][0]["transform"];
  times(t["scale"]);
  times(t["translate"]);
  for (auto& light : scene["lights"])
    for (const char* key : {"corner", "edge1", "edge2"}) times(light[key]);
  return scene;
}

TEST(Scale, TheSameSceneAt1eMinus4And1And1e4GivesTheSameImage) {
  test::TempDir dir;
  const json base = seedScene(32, 32);
  const test::Rendered reference = test::renderScene(test::loadSceneJson(dir, base, "unit.json"));
  for (double k : {1e-4, 1e4}) {
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scaled(base, k), "scaled.json"));
    expectSane(r, "scale " + std::to_string(k));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c] / reference.mean[c], 1.0, 0.01) << "scale " << k;
    // The same random numbers trace the same paths up to rounding: per pixel, nearly identical.
    double diff = 0, total = 0;
    for (size_t p = 0; p < r.image.rgb.size(); ++p) {
      diff += std::abs(double(r.image.rgb[p]) - reference.image.rgb[p]);
      total += reference.image.rgb[p];
    }
    EXPECT_LT(diff / total, 0.02) << "scale " << k;
  }
}

TEST(DegenerateGeometry, ZeroAreaNeedlesDuplicatesAndZeroNormalsStaySane) {
  test::TempDir dir;
  dir.write("bad.obj",
            "v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"          // a wall (1-4)
            "v -1 -1 1\nv 1 -1 1\n"                             // duplicate vertices (5, 6)
            "v 0 0 0.5\nv 0 0 0.5\nv 0 0 0.5\n"                 // a point (7-9)
            "v -0.5 0 0.6\nv 0.5 0 0.6\nv 0.5 0.0000001 0.6\n"  // a needle (10-12)
            "vn 0 0 0\n"
            "f 1//1 2//1 3//1\nf 1//1 3//1 4//1\nf 5 6 3\nf 7 8 9\nf 10 11 12\nf 1 1 2\n");
  json scene = test::minimalSceneJson();
  scene["shapes"] = json::array({{{"type", "obj"}, {"file", "bad.obj"}, {"material", "white"}}});
  scene["lights"][0] = {{"type", "quad"}, {"corner", {-0.5, -0.5, -1}}, {"edge1", {1, 0, 0}}, {"edge2", {0, 1, 0}},
                        {"radiance", 5},  {"visible_to_camera", false}};
  scene["render"]["max_bounces"] = 3;
  const Scene s = test::loadSceneJson(dir, scene);
  EXPECT_EQ(s.skippedDegenerateTriangles, 2u) << "the point and the repeated-vertex triangle";
  expectSane(test::renderScene(s), "degenerate mesh");
}

TEST(Grazing, ALitPlaneSeenAt89Point99DegreesHasNoBlackSpeckles) {
  // A camera looking along a large lit floor, 0.01 degrees above it. Every pixel that sees the
  // floor is lit directly (B = 1), so a black one means a self-shadowing shadow ray or a ray
  // that slipped under the floor. Measured: the count of such pixels must be zero.
  test::TempDir dir;
  const double angle = 0.01 * M_PI / 180.0;
  json scene = {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "pinhole"},
        {"position", {0, 1000 * std::tan(angle), -1000}},
        {"look_at", {0, 0, 0}},
        {"up", {0, 1, 0}},
        {"sensor_width", 0.01},
        {"focal_length", 0.1}}},
      {"materials", {{"floor", {{"type", "lambertian"}, {"albedo", 0.5}}}}},
      {"shapes", json::array({{{"type", "quad"},
                               {"corner", {-1e4, 0, -1e4}},
                               {"edge1", {0, 0, 2e4}},
                               {"edge2", {2e4, 0, 0}},
                               {"material", "floor"}}})},
      {"lights", json::array({{{"type", "quad"},
                               {"corner", {-3e3, 3e3, -3e3}},
                               {"edge1", {6e3, 0, 0}},
                               {"edge2", {0, 0, 6e3}},
                               {"radiance", 1},
                               {"visible_to_camera", false}}})},
      {"render", {{"resolution", {64, 64}}, {"samples_per_pixel", 4}, {"max_bounces", 1}}},
  };
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  int floorPixels = 0, black = 0;
  for (int y = 33; y < 64; ++y)  // below the horizon (the image's lower half sees the floor)
    for (int x = 0; x < 64; ++x) {
      ++floorPixels;
      if (r.image.at(x, y).g <= 0.0f) ++black;
    }
  EXPECT_GT(floorPixels, 900);
  EXPECT_EQ(black, 0) << "black speckles on a lit plane";
}

}  // namespace
}  // namespace lensfarm
