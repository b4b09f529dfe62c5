// The Blender add-on "Render on lensfarm" (blender/render_lensfarm, docs/blender.md) in Debian's
// Blender, headless, against a real coordinator (with a client token) and two real workers:
// tests/blender/addon_checks.py installs the add-on from its zip, builds each scene in code
// (every lamp kind, the world as a colour and as an image turned by a Mapping node, diffuse,
// glass, metal and textured surfaces, depth of field, a camera moving over 3 frames), renders it
// with Cycles, submits it through the add-on's operator and checks that the image is loaded into
// Blender, is `lensfarm render`'s of the exported scene bit for bit, and agrees with Cycles (image
// means within 3 % per channel, 8 x 8 blocks within 5 %, the blur pixel by pixel); that every
// setting the add-on cannot carry is reported by name; and that a wrong token and an unreachable
// coordinator come back as errors with the coordinator's message.
#include <gtest/gtest.h>

#include <cstdlib>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

bool have(const std::string& program) {
  return std::system(("command -v " + program + " > /dev/null 2>&1").c_str()) == 0;
}

class BlenderAddon : public test::FarmFixture {};

TEST_F(BlenderAddon, RendersEveryKindOfSceneAsCyclesDoesWithTheRenderersBits) {
  if (!have("blender")) GTEST_SKIP() << "no blender on PATH (scripts/setup.sh test installs Debian's)";
  const fs::path token = dir_.write("client.token", "the-blender-add-ons-token-3\n");
  fs::permissions(token, fs::perms::owner_read | fs::perms::owner_write);
  const std::string address = startCoordinator("127.0.0.1:0", {"--client-token-file", token.string()});
  startWorker(address, "w1");
  startWorker(address, "w2");
  const fs::path out = dir_ / "out";
  // A user folder of our own: the add-on is installed there, never into the real user's Blender.
  const auto r = test::runProcess({"/usr/bin/env",
                                   "BLENDER_USER_SCRIPTS=" + (dir_ / "blender-scripts").string(),
                                   "BLENDER_USER_CONFIG=" + (dir_ / "blender-config").string(),
                                   "TMPDIR=" + dir_.path().string(),
                                   "blender",
                                   "-b",
                                   "--factory-startup",
                                   "--python-exit-code",
                                   "2",
                                   "--python",
                                   (test::sourceDir() / "tests/blender/addon_checks.py").string(),
                                   "--",
                                   "--zip",
                                   (fs::path(LENSFARM_BINARY_DIR) / "blender/render_lensfarm.zip").string(),
                                   "--coordinator",
                                   address,
                                   "--token-file",
                                   token.string(),
                                   "--lensfarm",
                                   test::cliPath().string(),
                                   "--out",
                                   out.string(),
                                   "--unused-address",
                                   "127.0.0.1:" + std::to_string(test::freePort())},
                                  1500);
  std::string cases;
  for (size_t at = 0, end; (at = r.out.find("CASE ", at)) != std::string::npos; at = end) {
    end = r.out.find('\n', at);
    cases += r.out.substr(at, end - at) + "\n";
  }
  EXPECT_EQ(r.exitCode, 0) << cases << r.out.substr(r.out.size() > 20000 ? r.out.size() - 20000 : 0) << r.err;
  EXPECT_TRUE(test::contains(r.out, "PASSED")) << cases;
  std::cout << cases;
}

// `lensfarm blender install`: the add-on built with this lensfarm lands in the user's Blender (here
// a user folder of the test's), enabled, with the coordinator given, kept in Blender's saved
// preferences; a missing zip or Blender is exit 2 naming the flag.
TEST(BlenderInstall, PutsTheAddonIntoTheUsersBlenderEnabled) {
  if (!have("blender")) GTEST_SKIP() << "no blender on PATH (scripts/setup.sh test installs Debian's)";
  test::TempDir dir;
  const std::vector<std::string> env = {"/usr/bin/env", "BLENDER_USER_SCRIPTS=" + (dir / "scripts").string(),
                                        "BLENDER_USER_CONFIG=" + (dir / "config").string()};
  std::vector<std::string> install = env;
  install.insert(install.end(), {test::cliPath().string(), "blender", "install", "--coordinator", "farm.example:7878"});
  const auto r = test::runProcess(install, 300);
  ASSERT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_TRUE(test::contains(r.out, "installed and enabled Render on lensfarm: " + (dir / "scripts").string()));
  EXPECT_TRUE(fs::is_regular_file(dir / "scripts/addons/render_lensfarm/__init__.py"));
  EXPECT_TRUE(fs::is_regular_file(dir / "scripts/addons/render_lensfarm/vendor/lensfarm/v1/client_service_pb2.py"))
      << "the library travels with the add-on";
  // A new Blender session (its saved preferences) has it enabled, with the address.
  std::vector<std::string> check = env;
  check.insert(check.end(), {"blender", "-b", "--python-expr",
                             "import addon_utils, bpy; print('STATE', addon_utils.check('render_lensfarm'), "
                             "bpy.context.preferences.addons['render_lensfarm'].preferences.address)"});
  const auto c = test::runProcess(check, 300);
  EXPECT_TRUE(test::contains(c.out, "STATE (True, True) farm.example:7878")) << c.out << c.err;
  std::vector<std::string> badZip = env;
  badZip.insert(badZip.end(), {test::cliPath().string(), "blender", "install", "--zip", (dir / "none.zip").string()});
  const auto z = test::runProcess(badZip, 60);
  EXPECT_EQ(z.exitCode, 2);
  EXPECT_TRUE(test::contains(z.err, "--zip " + (dir / "none.zip").string()));
  const auto b =
      test::runProcess({test::cliPath().string(), "blender", "install", "--blender", "/nonexistent/blender"}, 60);
  EXPECT_EQ(b.exitCode, 2);
  EXPECT_TRUE(test::contains(b.err, "--blender /nonexistent/blender"));
}

// The add-on in Blender's real window (Xvfb): the default scene, Submit pressed as the button does
// (no waiting), the job followed by the add-on's timer while Blender's event loop runs, the image
// loaded, and the panel captured (tests/blender/panel_ui.py; docs/images/blender-panel.png).
TEST_F(BlenderAddon, ThePanelFollowsAJobWithoutBlockingBlendersWindow) {
  if (!have("blender") || !have("xvfb-run"))
    GTEST_SKIP() << "no blender or xvfb-run (scripts/setup.sh test installs both)";
  const std::string address = startCoordinator();
  startWorker(address, "w1");
  startWorker(address, "w2");
  const std::vector<std::string> env = {"/usr/bin/env", "BLENDER_USER_SCRIPTS=" + (dir_ / "blender-scripts").string(),
                                        "BLENDER_USER_CONFIG=" + (dir_ / "blender-config").string(),
                                        "TMPDIR=" + dir_.path().string()};
  // The default scene (cube, lamp, camera) saved as a file: opening a file skips the splash screen.
  const fs::path blend = dir_ / "default.blend";
  std::vector<std::string> save = env;
  save.insert(save.end(), {"blender", "-b", "--factory-startup", "--python-expr",
                           "import bpy; bpy.ops.wm.save_as_mainfile(filepath='" + blend.string() + "')"});
  ASSERT_EQ(test::runProcess(save, 120).exitCode, 0);
  std::vector<std::string> ui = env;
  ui.insert(ui.end(), {"xvfb-run", "-a", "-s", "-screen 0 1200x1400x24", "blender", "--factory-startup", blend.string(),
                       "--python", (test::sourceDir() / "tests/blender/panel_ui.py").string(), "--", "--zip",
                       (fs::path(LENSFARM_BINARY_DIR) / "blender/render_lensfarm.zip").string(), "--coordinator",
                       address, "--out", (dir_ / "shot").string()});
  const auto r = test::runProcess(ui, 600);
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_TRUE(test::contains(r.out, "PASSED")) << r.out << r.err;
  EXPECT_GT(fs::file_size(dir_ / "shot/panel.png"), 10000u) << "the panel's screenshot";
}

}  // namespace
}  // namespace lensfarm
