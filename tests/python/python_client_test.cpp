// The Python library `lensfarm` (python/lensfarm, docs/python.md) against a real coordinator with a
// client token and two real workers: tests/python/client_checks.py submits (a scene file with its
// OBJ, a dict with bytes, a model file), waits with a callback, downloads, lists, follows events,
// pauses, resumes, updates, cancels and deletes, and checks the typed errors (a bad scene field, an
// unknown job, a wrong token, an unreachable coordinator, a coordinator of another API). Here the
// image it downloaded must be `lensfarm render`'s of the same scene, bit for bit.
#include <gtest/gtest.h>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class PythonClient : public test::FarmFixture {};

TEST_F(PythonClient, SubmitsFollowsAndDownloadsTheRenderersBitsWithTypedErrors) {
  const fs::path token = dir_.write("client.token", "a-python-clients-token-7\n");
  fs::permissions(token, fs::perms::owner_read | fs::perms::owner_write);
  const std::string address = startCoordinator("127.0.0.1:0", {"--client-token-file", token.string()});
  startWorker(address, "w1");
  startWorker(address, "w2");
  const fs::path scene = writeScene(20, 8, 2);
  const fs::path out = dir_ / "from-python.exr";
  const auto r =
      test::runProcess({"/usr/bin/env", "PYTHONPATH=" + (fs::path(LENSFARM_BINARY_DIR) / "python").string(),
                        "/usr/bin/python3", (test::sourceDir() / "tests/python/client_checks.py").string(), "--address",
                        address, "--token-file", token.string(), "--scene", scene.string(), "--out", out.string(),
                        "--unused-address", "127.0.0.1:" + std::to_string(test::freePort())},
                       900);
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err << coordinator_->log();
  EXPECT_TRUE(test::contains(r.out, "all checks passed")) << r.out << r.err;
  // Workers render with the token-less flags of the fixture: the coordinator took no worker token.
  ImageMetadata farmMeta, localMeta;
  const Image farm = readExr(out, &farmMeta);
  const Image local = renderInProcess(scene, &localMeta);
  ASSERT_EQ(farm.rgb.size(), local.rgb.size());
  EXPECT_TRUE(farm.rgb == local.rgb) << "the image the Python client downloaded is the one-process render's";
}

}  // namespace
}  // namespace lensfarm
