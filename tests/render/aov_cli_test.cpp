// AOVs on the command line (docs/aovs.md): `lensfarm render --aov` writes the layers asked for
// and refuses an unknown name, and `--denoise` adds its guides, keeps the raw beauty and marks the
// file. Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "common/film/image_io.h"
#include "tests/render/aov_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;
using test::wallScene;

TEST(Aov, TheCommandLineWritesTheLayersAndRefusesAnUnknownName) {
  test::TempDir dir;
  const auto scene = dir.write("wall.json", wallScene({}).dump());
  const auto out = dir.path() / "out.exr";
  const auto ok = test::runProcess({test::cliPath().string(), "render", scene.string(), "-o", out.string(), "-q",
                                    "--aov", "albedo,depth", "--aov", "normal"});
  ASSERT_EQ(ok.exitCode, 0) << ok.err;
  const Image image = readExr(out);
  EXPECT_NE(image.layer("albedo"), nullptr);
  EXPECT_NE(image.layer("normal"), nullptr);
  EXPECT_NE(image.layer(""), nullptr) << "Z";
  EXPECT_EQ(image.layer("variance"), nullptr);

  const auto bad = test::runProcess({test::cliPath().string(), "render", scene.string(), "-o",
                                     (dir.path() / "bad.exr").string(), "-q", "--aov", "albedo,shadow"});
  EXPECT_EQ(bad.exitCode, 2) << bad.err;
  EXPECT_NE(bad.err.find("--aov"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("\"shadow\""), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "bad.exr"));
}

TEST(Aov, RenderDenoiseAddsTheGuidesKeepsTheRawBeautyAndMarksTheFile) {
  test::TempDir dir;
  json scene = test::bundledSceneJson("cornell-classic.json");
  scene["render"]["resolution"] = {48, 48};
  scene["render"]["samples_per_pixel"] = 4;
  const auto file = dir.write("classic.json", scene.dump());
  const auto denoisedOut = dir.path() / "denoised.exr", rawOut = dir.path() / "raw.exr";
  const auto d = test::runProcess({test::cliPath().string(), "render", file.string(), "-o", denoisedOut.string(), "-o",
                                   (dir.path() / "denoised.png").string(), "-q", "--denoise"});
  ASSERT_EQ(d.exitCode, 0) << d.err;
  const auto r = test::runProcess({test::cliPath().string(), "render", file.string(), "-o", rawOut.string(), "-q",
                                   "--aov", "albedo,normal,variance"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ImageMetadata meta;
  const Image denoised = readExr(denoisedOut, &meta), raw = readExr(rawOut);
  EXPECT_NE(meta.extra["denoised"].find("guided by albedo, normal, variance"), std::string::npos);
  for (const char* guide : {"albedo", "normal", "variance", "noisy"})
    EXPECT_NE(denoised.layer(guide), nullptr) << guide;
  EXPECT_TRUE(denoised.layer("noisy")->values == raw.rgb) << "the raw beauty, bit for bit";
  // Denoised is closer to a converged render than the raw image is (same samples), by relMSE
  // (Rousselle et al. 2011: (x - r)^2 / (r^2 + 0.01) per value), which the light's few very
  // bright pixels do not dominate.
  json converged = scene;
  converged["render"]["samples_per_pixel"] = 256;
  const Image reference = test::renderScene(test::loadSceneJson(dir, converged)).image;
  double errRaw = 0.0, errDenoised = 0.0;
  for (size_t k = 0; k < raw.rgb.size(); ++k) {
    const double norm = double(reference.rgb[k]) * reference.rgb[k] + 0.01;
    errRaw += std::pow(raw.rgb[k] - reference.rgb[k], 2.0) / norm;
    errDenoised += std::pow(denoised.rgb[k] - reference.rgb[k], 2.0) / norm;
  }
  EXPECT_LT(errDenoised, 0.5 * errRaw) << "relMSE sums: raw " << errRaw << ", denoised " << errDenoised;
}

}  // namespace
}  // namespace lensfarm
