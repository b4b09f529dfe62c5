// A scene renders the same at any scale and anywhere in the world: a floor, a block and an area
// light, moved and scaled as a whole (the camera by an angle, so nothing of it has a length),
// from a few tenths of a nanometre across (where Embree's float tests underflowed: the block was
// shaded black, measured 0.65 of the unit scene's red) to 1e16 across (where they overflowed:
// shadow rays passed the block, the image 8 % too bright at 1e14) and 2e7 from the origin.
// Each render's channel means are within 1 % of the unit scene's (the same samples, so only the
// rounding of the moved vertices differs).
// A floor of any size lights the same: the same scene on a floor 1e2 to 1e10 across, where
// Embree's float test is uncertain by ulps of the floor (a spawn margin of 4e3 at 1e10, which put
// every shadow ray from the floor above the lamp: the floor black, 0.04 of the image's mean).
#include <gtest/gtest.h>

#include <string>

#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

json sceneAt(double scale, DVec3 offset, double floor = 4.0) {
  const auto point = [&](DVec3 p) {
    return json{p.x * scale + offset.x, p.y * scale + offset.y, p.z * scale + offset.z};
  };
  const auto edge = [&](DVec3 e) { return json{e.x * scale, e.y * scale, e.z * scale}; };
  return {
      {"format", "lensfarm-scene/1"},
      {"render", {{"resolution", {24, 24}}, {"samples_per_pixel", 16}, {"max_bounces", 3}}},
      {"camera",
       {{"type", "pinhole"}, {"position", point({0, 1, 3})}, {"look_at", point({0, 0.5, 0})}, {"angle_of_view", 50}}},
      {"materials",
       {{"white", {{"type", "lambertian"}, {"albedo", 0.7}}},
        {"red", {{"type", "lambertian"}, {"albedo", {0.7, 0.1, 0.1}}}}}},
      {"shapes",
       {{{"type", "quad"},
         {"material", "white"},
         {"corner", point({-floor / 2, 0, -floor / 2})},
         {"edge1", edge({0, 0, floor})},
         {"edge2", edge({floor, 0, 0})}},
        {{"type", "quad"},
         {"material", "red"},
         {"corner", point({-0.5, 0, 0})},
         {"edge1", edge({1, 0, 0})},
         {"edge2", edge({0, 1, 0})}}}},
      {"lights",
       {{{"type", "quad"},
         {"corner", point({-0.25, 2, -0.25})},
         {"edge1", edge({0.5, 0, 0})},
         {"edge2", edge({0, 0, 0.5})},
         {"radiance", 10}}}}};
}

TEST(SceneScale, TheSameSceneAtAnyScaleAndPlaceRendersTheSame) {
  const test::TempDir dir;
  const test::Rendered unit = test::renderScene(test::loadSceneJson(dir, sceneAt(1.0, DVec3(0.0))));
  ASSERT_GT(unit.mean[0], 1.05 * unit.mean[1]) << "the red block must show";
  for (const auto& [scale, offset] :
       {std::pair{3e-10, DVec3(0.0)}, std::pair{1e-10, DVec3(0.0)}, std::pair{1e-6, DVec3(1e3, 0, 0)},
        std::pair{1e10, DVec3(0.0)}, std::pair{1e14, DVec3(0.0)}, std::pair{1e16, DVec3(3e16, 0, 0)},
        std::pair{1.0, DVec3(1e7, -3e6, 2e7)}}) {
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, sceneAt(scale, offset)));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.mean[c], unit.mean[c], 0.01 * unit.mean[c])
          << "scale " << scale << " at " << offset.x << ", channel " << c;
  }
}

TEST(SceneScale, AFloorOfAnySizeUnderTheSceneLightsItTheSame) {
  const test::TempDir dir;
  // The reference: a floor of 100, whose float margin (5e-6) is far below anything in the scene.
  const test::Rendered reference = test::renderScene(test::loadSceneJson(dir, sceneAt(1.0, DVec3(0.0), 1e2)));
  ASSERT_GT(reference.mean[0], 1.05 * reference.mean[1]) << "the red block must show";
  for (const double floor : {1e4, 1e6, 1e8, 1e10}) {
    for (const DVec3 offset : {DVec3(0.0), DVec3(1e3, 0.0, -2e3)}) {
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, sceneAt(1.0, offset, floor)));
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(r.mean[c], reference.mean[c], 0.01 * reference.mean[c])
            << "floor " << floor << " at " << offset.x << ", channel " << c;
    }
  }
}

TEST(SceneScale, ALightOf1eMinus12AreaKeepsItsPower) {
  // The lamp shrunk to a square of side w with its power held (radiance 10 x 0.25 / w^2), off
  // centre so that its float corners round: at w = 1e-6, 2 from the camera, rounding alone took
  // ~5 % of its area (and of the image). Each within 1 % of the same lamp at w = 1e-3.
  const test::TempDir dir;
  const auto withLamp = [&](double w) {
    json scene = sceneAt(1.0, DVec3(0.0));
    scene["lights"][0]["corner"] = {0.1234567, 2.0000003, -0.3333333};
    scene["lights"][0]["edge1"] = {w, 0, 0};
    scene["lights"][0]["edge2"] = {0, 0, w};
    scene["lights"][0]["radiance"] = 10.0 * 0.25 / (w * w);
    return test::renderScene(test::loadSceneJson(dir, scene));
  };
  const test::Rendered reference = withLamp(1e-3);
  for (const double w : {1e-5, 1e-6}) {
    const test::Rendered r = withLamp(w);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.mean[c], reference.mean[c], 0.01 * reference.mean[c]) << "side " << w << ", channel " << c;
  }
}

}  // namespace
}  // namespace lensfarm
