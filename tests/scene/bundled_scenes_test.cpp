// Every scene shipped in scenes/ loads as it is (its meshes and maps found relative to it) and is
// described in scenes/README.md: the folder holds only scenes a user can render.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

TEST(BundledScenes, EveryShippedSceneLoadsAndIsDescribed) {
  const std::string readme = test::readFile(test::scenesDir() / "README.md");
  int scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test::scenesDir())) {
    if (entry.path().extension() != ".json") continue;
    ++scenes;
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    const Scene scene = loadScene(entry.path());
    EXPECT_GT(scene.meshes.size(), 0u);
    EXPECT_NE(readme.find("`" + name + "`"), std::string::npos) << "scenes/README.md does not describe it";
  }
  EXPECT_GE(scenes, 5);
}

}  // namespace
}  // namespace lensfarm
