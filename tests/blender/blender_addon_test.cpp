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

bool haveBlender() { return std::system("command -v blender > /dev/null 2>&1") == 0; }

class BlenderAddon : public test::FarmFixture {};

TEST_F(BlenderAddon, RendersEveryKindOfSceneAsCyclesDoesWithTheRenderersBits) {
  if (!haveBlender()) GTEST_SKIP() << "no blender on PATH (scripts/setup.sh test installs Debian's)";
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

}  // namespace
}  // namespace lensfarm
