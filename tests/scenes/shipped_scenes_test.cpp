// scenes/ holds only scenes a user can render, and says what each is: every scene in it renders
// through the real `lensfarm` binary (at a tiny size), every other file is a mesh or texture some
// scene uses (or a model some scene uses refers to) or the folder's README, and the README names every scene. Anything else there (a
// fuzzer's corpus, a stray output) fails this test.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "film/image_io.h"
#include "test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> sceneFiles() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(test::scenesDir()))
    if (e.is_regular_file() && e.path().extension() == ".json") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ShippedScenes, EveryFileIsASceneTheReadmeOrAnAssetASceneUses) {
  const std::vector<fs::path> scenes = sceneFiles();
  ASSERT_GE(scenes.size(), 2u);
  std::string sceneTexts;
  for (const fs::path& s : scenes) sceneTexts += test::readFile(s);
  const std::string readme = test::readFile(test::scenesDir() / "README.md");
  size_t files = 0;
  for (auto walk = fs::recursive_directory_iterator(test::scenesDir()); walk != fs::recursive_directory_iterator(); ++walk) {
    if (walk->is_directory()) continue;
    ++files;
    const fs::path relative = fs::relative(walk->path(), test::scenesDir());
    SCOPED_TRACE(relative.string());
    if (relative == "README.md") continue;
    if (relative.parent_path().empty()) {
      EXPECT_EQ(relative.extension(), ".json") << "only scenes and the README at the top of scenes/";
      EXPECT_NE(readme.find(relative.string()), std::string::npos) << "scenes/README.md does not describe it";
    } else if (relative.parent_path() == "lenses") {
      // The lens library (docs/optics.md): prescriptions for real_lens cameras and `lensfarm lens`,
      // each listed in the README.
      EXPECT_EQ(relative.extension(), ".dat");
      EXPECT_NE(readme.find(relative.filename().string()), std::string::npos) << "scenes/README.md does not list it";
    } else {
      // Used by a scene, or by a model a scene uses (a glTF's buffers and images, an MTL's maps),
      // which names it relative to itself.
      bool used = sceneTexts.find("\"" + relative.generic_string() + "\"") != std::string::npos;
      for (const auto& sibling : fs::directory_iterator(walk->path().parent_path())) {
        const std::string ext = sibling.path().extension().string();
        if (ext != ".gltf" && ext != ".mtl") continue;
        const std::string model = fs::relative(sibling.path(), test::scenesDir()).generic_string();
        const std::string text = test::readFile(sibling.path()), name = relative.filename().string();
        used |= sceneTexts.find("\"" + model + "\"") != std::string::npos &&
                (text.find("\"" + name + "\"") != std::string::npos || (ext == ".mtl" && text.find(" " + name) != std::string::npos));
      }
      EXPECT_TRUE(used) << "no scene uses it";
    }
  }
  EXPECT_LT(files, 40u) << "scenes/ is for scenes, not corpora";
}

TEST(ShippedScenes, EverySceneRendersThroughTheCli) {
  test::TempDir dir;
  for (const fs::path& scene : sceneFiles()) {
    SCOPED_TRACE(scene.string());
    const fs::path exr = dir / (scene.stem().string() + ".exr"), png = dir / (scene.stem().string() + ".png");
    const auto r = test::runProcess({test::cliPath().string(), "render", scene.string(), "--resolution", "24x24", "--spp", "2",
                                     "-q", "-o", exr.string(), "-o", png.string()},
                                    300);
    EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
    ASSERT_TRUE(fs::exists(exr) && fs::exists(png));
    ImageMetadata metadata;
    const Image image = readExr(exr, &metadata);
    EXPECT_EQ(image.width, 24);
    EXPECT_EQ(image.height, 24);
    EXPECT_EQ(metadata.samplesPerPixel, 2u);
    double sum = 0.0;
    for (const float v : image.rgb) sum += v;
    EXPECT_GT(sum, 0.0) << "the scene is lit";
    EXPECT_NE(r.out.find("samples per pixel: 2"), std::string::npos) << r.out;
  }
}

}  // namespace
}  // namespace lensfarm
