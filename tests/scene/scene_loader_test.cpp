// Scene loading: the shipped scenes load as the 2013 report describes them.
#include <gtest/gtest.h>

#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

TEST(SceneLoader, SeedSceneMatchesTheReport) {
  const Scene scene = loadScene(test::scenesDir() / "cornell-seed.json");
  size_t triangles = 0;
  for (const auto& m : scene.meshes) triangles += m.triangleCount();
  EXPECT_EQ(triangles, 30u + 2u);  // the DH2323 box and one quad light
  const ThinLensCamera camera = scene.camera();
  EXPECT_DOUBLE_EQ(camera.params().focusDistance, 2.9);
  EXPECT_DOUBLE_EQ(camera.params().focalLength, 0.095);
  EXPECT_DOUBLE_EQ(camera.params().sensorWidth, 0.1);
  EXPECT_NEAR(camera.lensRadius(), 0.095 / (2 * 16), 1e-12);  // 2013 report eq. 7
  EXPECT_NEAR(camera.imageDistance(), 0.0982, 5e-5);          // 2013 report §4.6: S2 ~ 0.0982
  EXPECT_EQ(scene.render.maxBounces, 2);
  EXPECT_FALSE(scene.render.mirrorBouncesCount);
}

TEST(SceneLoader, BoxIsMappedIntoTheUnitCubeWithTheFloorAtPlusY) {
  const Scene scene = loadScene(test::scenesDir() / "cornell-classic.json");
  const TriangleMesh& box = scene.meshes.front();
  // Positions are in render space (the camera at the origin); the file's world is origin + p.
  const auto world = [&](uint32_t k) { return Vec3(DVec3(box.positions[k]) + scene.origin); };
  Vec3 lo(1e9f), hi(-1e9f);
  for (uint32_t k = 0; k < box.positions.size(); ++k) {
    lo = glm::min(lo, world(k));
    hi = glm::max(hi, world(k));
  }
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(lo[c], -1.0f, 1e-5f);
    EXPECT_NEAR(hi[c], 1.0f, 1e-5f);
  }
  // The floor (the OBJ's first group, 2 triangles) lies at y = +1: y points down in the image.
  for (size_t k = 0; k < 6; ++k) EXPECT_NEAR(world(box.indices[k]).y, 1.0f, 1e-5f);
  // Every wall faces into the room: its normal points towards the centre.
  for (size_t t = 0; t < 10; ++t) {
    const Vec3 a = world(box.indices[3 * t]), b = world(box.indices[3 * t + 1]), c = world(box.indices[3 * t + 2]);
    const Vec3 n = glm::cross(b - a, c - a);
    EXPECT_LT(glm::dot(n, a), 0.0f) << "triangle " << t << " faces outwards";
  }
}

TEST(SceneLoader, HashCoversTheSceneAndItsAssets) {
  test::TempDir dir;
  const auto obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  dir.write("m.obj", obj);
  nlohmann::json j = test::minimalSceneJson();
  j["shapes"].push_back({{"type", "obj"}, {"file", "m.obj"}, {"material", "white"}});
  const std::string h1 = test::loadSceneJson(dir, j).hash;
  EXPECT_EQ(h1, test::loadSceneJson(dir, j).hash);
  EXPECT_EQ(h1.size(), 64u);
  dir.write("m.obj", "v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(h1, test::loadSceneJson(dir, j).hash) << "an edited OBJ must change the scene hash";
  j["render"]["seed"] = 8;
  dir.write("m.obj", obj);
  EXPECT_NE(h1, test::loadSceneJson(dir, j).hash);
}

TEST(SceneLoader, ZeroAreaTrianglesAreSkippedAndCounted) {
  test::TempDir dir;
  nlohmann::json j = test::minimalSceneJson();
  j["shapes"].push_back({{"type", "triangles"},
                         {"material", "white"},
                         {"vertices", {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}});
  const Scene scene = test::loadSceneJson(dir, j);
  EXPECT_EQ(scene.skippedDegenerateTriangles, 2u);
}

}  // namespace
}  // namespace lensfarm
