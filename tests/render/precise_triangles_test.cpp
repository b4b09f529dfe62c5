// Triangles too large for Embree's float test are tested in double (render/precise_triangles.h):
// which ones, what a ray spawned from them reaches, and that ordinary scenes have none (so they
// keep every bit).
#include "common/render/precise_triangles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/math/ray_offset.h"
#include "common/render/ray_caster.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

// A floor `size` across at y = -1 (the camera, at render space's origin, 1 above it), a unit
// block standing on it and a lamp quad 2 above the floor, facing down.
json floorScene(double size) {
  return {{"format", "lensfarm-scene/1"},
          {"render", {{"resolution", {8, 8}}, {"samples_per_pixel", 1}}},
          {"camera", {{"type", "pinhole"}, {"position", {0, 1, 3}}, {"look_at", {0, 0.5, 0}}, {"angle_of_view", 50}}},
          {"materials", {{"white", {{"type", "lambertian"}, {"albedo", 0.7}}}}},
          {"shapes",
           {{{"type", "quad"},
             {"material", "white"},
             {"corner", {-size / 2, 0, -size / 2}},
             {"edge1", {0, 0, size}},
             {"edge2", {size, 0, 0}}},
            {{"type", "quad"},
             {"material", "white"},
             {"corner", {-0.5, 0, 0}},
             {"edge1", {1, 0, 0}},
             {"edge2", {0, 1, 0}}}}},
          {"lights",
           {{{"type", "quad"},
             {"corner", {-0.25, 2, -0.25}},
             {"edge1", {0.5, 0, 0}},
             {"edge2", {0, 0, 0.5}},
             {"radiance", 10}}}}};
}

size_t preciseCount(const Scene& scene) {
  size_t n = 0;
  for (const auto& mesh : preciseTrianglesOf(scene)) n += mesh.size();
  return n;
}

TEST(PreciseTriangles, OnlyTrianglesFarLargerThanTheScenesFeaturesAreTestedInDouble) {
  const test::TempDir dir;
  EXPECT_EQ(preciseCount(test::loadSceneJson(dir, floorScene(100.0))), 0u);
  EXPECT_EQ(preciseCount(test::loadSceneJson(dir, floorScene(1e4))), 0u) << "a margin of 4e-3 against features of 1";
  EXPECT_EQ(preciseCount(test::loadSceneJson(dir, floorScene(1e10))), 2u) << "the floor's two triangles";
}

TEST(PreciseTriangles, NoShippedSceneHasAny) {
  // Every scene in scenes/ keeps the bits it had before precise triangles existed.
  for (const auto& entry : std::filesystem::directory_iterator(test::scenesDir())) {
    if (entry.path().extension() != ".json") continue;
    const Scene scene = loadScene(entry.path());
    EXPECT_EQ(preciseCount(scene), 0u) << entry.path().filename();
  }
}

TEST(PreciseTriangles, ARayFromAHugeFloorReachesTheLampJustAboveIt) {
  // From points of the floor near the block, straight up: the lamp is 2 above. With Embree's
  // float test the ray had to start ~4e3 above a 1e10 floor (its margin) and missed the lamp.
  const test::TempDir dir;
  for (const double size : {1e4, 1e7, 1e10}) {
    const bool precise = size > 1e5;  // (1e4: Embree's own test, a margin of 4e-3)
    const Scene scene = test::loadSceneJson(dir, floorScene(size));
    const RayCaster caster(scene);
    for (const float x : {-0.2f, 0.0f, 0.13f}) {
      const Vec3 below(x, -0.5f, -3.0f + 0.1f);  // render space: the camera at the origin
      const auto floor = caster.intersect(below, glm::normalize(Vec3(0.0f, -1.0f, 0.2f)), RayKind::kScattered);
      ASSERT_TRUE(floor) << size;
      EXPECT_NEAR(floor->p.y, -1.0f, 1e-6f) << "the hit point lies on the floor: " << size;
      EXPECT_LT(floor->margin, precise ? 1e-4f : 1e-2f) << size;
      const Vec3 up(0.0f, 1.0f, 0.0f);
      const Vec3 from = spawnOrigin(floor->p, floor->plane(), up);
      EXPECT_GT(from.y, -1.0f) << size;
      EXPECT_LT(from.y, -1.0f + (precise ? 1e-4f : 1e-2f)) << size;
      const auto lamp = caster.intersect(from, up, RayKind::kScattered);
      ASSERT_TRUE(lamp) << size;
      EXPECT_NEAR(lamp->t, 1.0f - from.y, 1e-5f) << "the lamp 2 above the floor: " << size;
      // And the shadow-ray form: the segment to a point just short of the lamp is clear, the
      // floor itself not in the way.
      EXPECT_FALSE(caster.occluded(from, up, 1.99f)) << size;
      // The other way, down through the floor: blocked.
      EXPECT_TRUE(caster.occluded(from + Vec3(0.0f, 0.5f, 0.0f), -up, 1.0f)) << size;
    }
  }
}

}  // namespace
}  // namespace lensfarm
