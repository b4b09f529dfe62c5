// A scene renders the same at any scale and anywhere in the world: a floor, a block and an area
// light, moved and scaled as a whole (the camera by an angle, so nothing of it has a length),
// from a few tenths of a nanometre across (where Embree's float tests underflowed: the block was
// shaded black, measured 0.65 of the unit scene's red) to 1e10 across and 2e7 from the origin.
// Each render's channel means are within 1 % of the unit scene's (the same samples, so only the
// rounding of the moved vertices differs).
#include <gtest/gtest.h>

#include <string>

#include "scene/scene_loader.h"
#include "test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

json sceneAt(double scale, DVec3 offset) {
  const auto point = [&](DVec3 p) { return json{p.x * scale + offset.x, p.y * scale + offset.y, p.z * scale + offset.z}; };
  const auto edge = [&](DVec3 e) { return json{e.x * scale, e.y * scale, e.z * scale}; };
  return {{"format", "lensfarm-scene/1"},
          {"render", {{"resolution", {24, 24}}, {"samples_per_pixel", 16}, {"max_bounces", 3}}},
          {"camera",
           {{"type", "pinhole"}, {"position", point({0, 1, 3})}, {"look_at", point({0, 0.5, 0})}, {"angle_of_view", 50}}},
          {"materials",
           {{"white", {{"type", "lambertian"}, {"albedo", 0.7}}},
            {"red", {{"type", "lambertian"}, {"albedo", {0.7, 0.1, 0.1}}}}}},
          {"shapes",
           {{{"type", "quad"}, {"material", "white"}, {"corner", point({-2, 0, -2})}, {"edge1", edge({0, 0, 4})},
             {"edge2", edge({4, 0, 0})}},
            {{"type", "quad"}, {"material", "red"}, {"corner", point({-0.5, 0, 0})}, {"edge1", edge({1, 0, 0})},
             {"edge2", edge({0, 1, 0})}}}},
          {"lights",
           {{{"type", "quad"}, {"corner", point({-0.25, 2, -0.25})}, {"edge1", edge({0.5, 0, 0})},
             {"edge2", edge({0, 0, 0.5})}, {"radiance", 10}}}}};
}

TEST(SceneScale, TheSameSceneAtAnyScaleAndPlaceRendersTheSame) {
  const test::TempDir dir;
  const test::Rendered unit = test::renderScene(test::loadSceneJson(dir, sceneAt(1.0, DVec3(0.0))));
  ASSERT_GT(unit.mean[0], 1.05 * unit.mean[1]) << "the red block must show";
  for (const auto& [scale, offset] : {std::pair{3e-10, DVec3(0.0)}, std::pair{1e-10, DVec3(0.0)},
                                      std::pair{1e-6, DVec3(1e3, 0, 0)}, std::pair{1e10, DVec3(0.0)},
                                      std::pair{1.0, DVec3(1e7, -3e6, 2e7)}}) {
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, sceneAt(scale, offset)));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.mean[c], unit.mean[c], 0.01 * unit.mean[c])
          << "scale " << scale << " at " << offset.x << ", channel " << c;
  }
}

}  // namespace
}  // namespace lensfarm
