// A model file as a scene on the command line: `lensfarm render model.glb` renders a model with
// its defaults (a framing camera, studio lights) and says so. Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(ModelScene, RenderingAModelFileUsesItsDefaultsAndSaysSo) {
  // A glTF cube with neither camera nor lights: framed, lit by the white environment.
  test::TempDir dir;
  test::Builder b;
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
  const std::vector<uint16_t> idx = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                     3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
  b.doc["meshes"] = json::array(
      {{{"primitives", {{{"attributes", {{"POSITION", b.floats(p, "VEC3")}}}, {"indices", b.indices(idx)}}}}}});
  b.doc["nodes"] = json::array({{{"mesh", 0}}});
  writeFile(dir.path() / "cube.glb", b.glb());

  std::string text;
  const Scene scene = modelScene(dir.path() / "cube.glb", text);
  EXPECT_EQ(scene.render.width, 1280);
  EXPECT_EQ(scene.render.height, 720);
  // Without lights of its own: the studio key light and the environment's fill.
  ASSERT_EQ(scene.lights.size(), 2u);
  EXPECT_STREQ(scene.lights[0]->type(), "directional");
  EXPECT_STREQ(scene.lights[1]->type(), "environment");
  // The framing camera looks at the cube's centre.
  const ThinLensCamera camera = scene.camera();
  const Vec3 toCentre = glm::normalize(Vec3(DVec3(0.5) - scene.origin) - camera.params().position);
  EXPECT_GT(glm::dot(toCentre, glm::normalize(camera.params().lookAt - camera.params().position)), 0.9999f);

  const auto result =
      test::runProcess({test::cliPath().string(), "render", (dir.path() / "cube.glb").string(), "--resolution", "32x18",
                        "--spp", "4", "-o", (dir.path() / "cube.exr").string(), "--quiet"});
  const std::string output = result.out + result.err;
  ASSERT_EQ(result.exitCode, 0) << output;
  EXPECT_NE(output.find("framing"), std::string::npos) << output;
  EXPECT_NE(output.find("lit as in a studio"), std::string::npos) << output;
  const Image image = readExr(dir.path() / "cube.exr");
  EXPECT_EQ(image.width, 32);
  double sum = 0;
  for (float v : image.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
}

}  // namespace
}  // namespace lensfarm
