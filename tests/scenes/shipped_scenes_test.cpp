// scenes/ holds only scenes a user can render, and says what each is: every scene in it renders
// through the real `lensfarm` binary (at a tiny size), every other file is a mesh or texture some
// scene uses (or a model some scene uses refers to) or the folder's README, and the README names every scene. Anything
// else there (a fuzzer's corpus, a stray output) fails this test.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "common/film/image_io.h"
#include "tests/test_support.h"

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
  for (auto walk = fs::recursive_directory_iterator(test::scenesDir()); walk != fs::recursive_directory_iterator();
       ++walk) {
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
    } else if (*relative.begin() == "usd") {
      // A USD layer a scene uses, or a file (layer, texture) a USD layer names as an @asset@ path
      // relative to itself.
      bool used = sceneTexts.find("\"" + relative.generic_string() + "\"") != std::string::npos;
      for (const auto& layer : fs::recursive_directory_iterator(test::scenesDir() / "usd"))
        if (layer.path().extension() == ".usda")
          used |= test::readFile(layer.path())
                      .find("@" + fs::relative(walk->path(), layer.path().parent_path()).generic_string() + "@") !=
                  std::string::npos;
      EXPECT_TRUE(used) << "no scene or USD layer uses it";
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
                (text.find("\"" + name + "\"") != std::string::npos ||
                 (ext == ".mtl" && text.find(" " + name) != std::string::npos));
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
    const auto r = test::runProcess({test::cliPath().string(), "render", scene.string(), "--resolution", "24x24",
                                     "--spp", "2", "-q", "-o", exr.string(), "-o", png.string()},
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

// Every shipped scene renders the same bits as when tests/scenes/golden_bits.txt was written: a guard
// for changes of shape (layout, interfaces, refactors) that must not change a single pixel. The
// traversal kernel is pinned to SSE2 so that the hashes do not depend on this machine's instruction
// sets (Embree's kernels differ in the last bits of a hit). A change meant to alter images rewrites
// the file: LENSFARM_UPDATE_GOLDEN=1 build/tests/lensfarm_e2e_tests
// --gtest_filter='ShippedScenes.EverySceneKeepsItsBits'.
uint64_t fnv1a(const std::vector<float>& values) {
  uint64_t h = 1469598103934665603ull;
  for (const float v : values) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    for (int b = 0; b < 4; ++b) h = (h ^ ((bits >> (8 * b)) & 0xffu)) * 1099511628211ull;
  }
  return h;
}

TEST(ShippedScenes, EverySceneKeepsItsBits) {
  const fs::path goldenFile = test::sourceDir() / "tests" / "scenes" / "golden_bits.txt";
  const bool update = std::getenv("LENSFARM_UPDATE_GOLDEN") != nullptr;
  std::map<std::string, std::string> golden;
  if (!update) {
    std::ifstream in(goldenFile);
    std::string name, hash;
    while (in >> name >> hash) golden[name] = hash;
    ASSERT_FALSE(golden.empty()) << goldenFile;
  }
  ::setenv("LENSFARM_EMBREE_CONFIG", "isa=sse2", 1);
  test::TempDir dir;
  std::ofstream out;
  if (update) out.open(goldenFile);
  for (const fs::path& scene : sceneFiles()) {
    SCOPED_TRACE(scene.string());
    const fs::path exr = dir / (scene.stem().string() + ".exr");
    const auto r = test::runProcess({test::cliPath().string(), "render", scene.string(), "--resolution", "32x24",
                                     "--spp", "4", "--threads", "2", "-q", "-o", exr.string()},
                                    300);
    ASSERT_EQ(r.exitCode, 0) << r.out << r.err;
    char hash[17];
    std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(fnv1a(readExr(exr).rgb)));
    const std::string name = scene.filename().string();
    if (update)
      out << name << " " << hash << "\n";
    else
      EXPECT_EQ(golden[name], hash) << "the scene's pixels changed";
  }
  ::unsetenv("LENSFARM_EMBREE_CONFIG");
}

}  // namespace
}  // namespace lensfarm
