// A USD stage on the farm (docs/scene-format.md "USD"): `lensfarm submit scene.usda` ships the
// stage, the layer it references and its texture as assets (nothing else from the client's disk),
// two real workers render it, and the image is `lensfarm render`'s of the same file, bit for bit.
#include <gtest/gtest.h>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class UsdFarm : public test::FarmFixture {};

TEST_F(UsdFarm, AStageWithItsReferencedLayerAndTextureRendersTheSameBitsOnTwoWorkers) {
  // The shipped example, copied: its layer and texture beside it as the stage names them.
  fs::copy(test::scenesDir() / "usd", dir_ / "usd", fs::copy_options::recursive);
  const fs::path stage = dir_ / "usd/studio.usda";
  const std::string address = startCoordinator();
  startWorker(address, "w1");
  startWorker(address, "w2");
  const std::string job = submit(address, stage, {"--resolution", "48x27", "--spp", "8"});
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  const fs::path farmExr = dir_ / "farm.exr", localExr = dir_ / "local.exr";
  ASSERT_EQ(cli({"download", job, "-o", farmExr.string(), "--coordinator", address}).exitCode, 0);
  ASSERT_EQ(
      cli({"render", stage.string(), "--resolution", "48x27", "--spp", "8", "-q", "-o", localExr.string()}).exitCode,
      0);
  const Image farm = readExr(farmExr), local = readExr(localExr);
  ASSERT_EQ(farm.rgb.size(), local.rgb.size());
  EXPECT_TRUE(farm.rgb == local.rgb) << "a USD job's image is the render's, bit for bit";
  // The workers fetched the three files (stage, referenced layer, texture) into their caches.
  size_t cached = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir_ / "cache-w1")) cached += e.is_regular_file();
  for (const auto& e : fs::recursive_directory_iterator(dir_ / "cache-w2")) cached += e.is_regular_file();
  EXPECT_GE(cached, 3u);
}

}  // namespace
}  // namespace lensfarm
