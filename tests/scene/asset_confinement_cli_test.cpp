// Files a scene names stay inside its folder (scene/asset_path.h) on the command line: `lensfarm
// render` and `lensfarm submit` refuse a mesh that climbs out with exit code 2, and read it once its
// folder is allowed (--allow-path). Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/scene/asset_confinement_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::Layout;

TEST(AssetConfinement, RenderAndSubmitRefuseWithExitCode2) {
  const Layout l;
  const fs::path scene = l.sceneWithMesh("../secret.obj");
  const auto render = test::runProcess(
      {test::cliPath().string(), "render", scene.string(), "-o", (l.dir / "out.png").string(), "--spp", "1"});
  EXPECT_EQ(render.exitCode, test::kBadInput) << render.err;
  EXPECT_TRUE(test::contains(render.err, "lies outside"));
  EXPECT_FALSE(fs::exists(l.dir / "out.png"));
  const std::string coordinator = "127.0.0.1:" + std::to_string(test::freePort());
  const auto submit =
      test::runProcess({test::cliPath().string(), "submit", scene.string(), "--coordinator", coordinator});
  EXPECT_EQ(submit.exitCode, test::kBadInput) << submit.err;
  EXPECT_TRUE(test::contains(submit.err, "lies outside"));
  // Allowed, the scene is read and the submit goes on to the (absent) coordinator: exit 3.
  const auto allowed = test::runProcess({test::cliPath().string(), "submit", scene.string(), "--coordinator",
                                         coordinator, "--allow-path", l.dir.path().string()});
  EXPECT_EQ(allowed.exitCode, 3) << allowed.err;
  const auto rendered =
      test::runProcess({test::cliPath().string(), "render", scene.string(), "-o", (l.dir / "out.png").string(), "--spp",
                        "1", "--resolution", "8x8", "--allow-path", l.dir.path().string()});
  EXPECT_EQ(rendered.exitCode, 0) << rendered.err;
}

}  // namespace
}  // namespace lensfarm
