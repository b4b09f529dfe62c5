// `--target-error` and `--deadline` through the CLI, judged against an independent reference.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "common/film/error_metrics.h"
#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path smallClassicBox(const test::TempDir& dir, int side) {
  json scene = test::bundledSceneJson("cornell-classic.json");
  scene["render"]["resolution"] = {side, side};
  return dir.write("classic.json", scene.dump());
}

fs::path smallSeedBox(const test::TempDir& dir, int side) {
  json scene = json::parse(std::ifstream(test::scenesDir() / "cornell-seed.json"));
  for (auto& shape : scene["shapes"])
    if (shape.contains("file")) shape["file"] = (test::scenesDir() / shape["file"].get<std::string>()).string();
  scene["render"]["resolution"] = {side, side};
  return dir.write("seed.json", scene.dump());
}

TEST(StoppingRules, ATargetErrorRenderLandsWithinAFactorOfOnePointFiveOfItsTarget) {
  test::TempDir dir;
  const fs::path scene = smallSeedBox(dir, 24);
  // The reference: its own seed (shared random numbers would hide error), NEE + MIS with Sobol
  // samples at 8192 spp, far below the target's error (about 0.1 %).
  const auto ref = test::runProcess({test::cliPath().string(), "render", scene.string(), "--spp", "8192", "--seed",
                                     "777", "-q", "-o", (dir / "ref.exr").string()},
                                    300);
  ASSERT_EQ(ref.exitCode, 0) << ref.err;
  for (const char* sampler : {"independent", "sobol"}) {
    const double target = 0.05;
    const auto r = test::runProcess({test::cliPath().string(), "render", scene.string(), "--target-error", "0.05",
                                     "--spp", "16384", "--sampler", sampler, "-q", "-o", (dir / "target.exr").string()},
                                    300);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("stopped:           target error reached"), std::string::npos) << r.out;
    ImageMetadata meta;
    const Image image = readExr(dir / "target.exr", &meta);
    EXPECT_LT(meta.samplesPerPixel, 16384u) << "stopped before the cap";
    const ImageError e = compareImages(image, readExr(dir / "ref.exr"));
    EXPECT_LT(e.relativeRmse, 1.5 * target) << sampler << " at " << meta.samplesPerPixel << " spp";
    EXPECT_GT(e.relativeRmse, target / 1.5) << sampler << " at " << meta.samplesPerPixel << " spp";
  }
}

// A camera that sees nothing lit: every unit is black, so the estimated error is unknown from the
// first unit to the last, and the job runs to its sample cap instead of stopping at 0 %.
TEST(StoppingRules, ATargetErrorRenderOfABlackImageNeverStopsOnAnUnknownEstimate) {
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  scene["camera"]["look_at"] = {0, 0, -6};  // away from the wall and the light
  scene["render"]["samples_per_unit"] = 1;
  const fs::path path = dir.write("black.json", scene.dump());
  const auto r = test::runProcess({test::cliPath().string(), "render", path.string(), "--target-error", "0.05", "--spp",
                                   "6", "--progress-every", "0.1", "-o", (dir / "black.exr").string()},
                                  120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("samples per pixel: 6\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("estimated error:   unknown\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stopped:           sample cap reached before the target error"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("err 0.00 %"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("done 6/6 spp  err unknown (target 5.00 %)"), std::string::npos) << r.err;
}

TEST(StoppingRules, ADeadlineRenderKeepsWholeUnitsAndSaysWhyItStopped) {
  test::TempDir dir;
  const fs::path scene = smallClassicBox(dir, 64);
  const auto r = test::runProcess({test::cliPath().string(), "render", scene.string(), "--deadline", "1.5s", "-q", "-o",
                                   (dir / "out.exr").string()},
                                  120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("stopped:           deadline reached"), std::string::npos) << r.out;
  ImageMetadata meta;
  readExr(dir / "out.exr", &meta);
  EXPECT_GT(meta.samplesPerPixel, 0u);
  EXPECT_EQ(meta.samplesPerPixel % 16, 0u) << "units of 16 spp (a deadline job at 64x64): whole passes only";
  EXPECT_EQ(meta.totalSamples, meta.samplesPerPixel * 64u * 64u) << "every pixel has every sample";
}

TEST(StoppingRules, BadRulesAreRefusedByFlag) {
  test::TempDir dir;
  const fs::path scene = smallClassicBox(dir, 8);
  for (const auto& [flag, value] : std::vector<std::pair<std::string, std::string>>{
           {"--target-error", "1.5"}, {"--target-error", "-0.1"}, {"--deadline", "soon"}, {"--deadline", "0s"}}) {
    const auto r = test::runProcess(
        {test::cliPath().string(), "render", scene.string(), flag, value, "-q", "-o", (dir / "x.exr").string()}, 30);
    EXPECT_EQ(r.exitCode, 2) << flag << " " << value;
    EXPECT_NE(r.err.find(flag), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "x.exr"));
  }
}

}  // namespace
}  // namespace lensfarm
