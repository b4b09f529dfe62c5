// AOVs on the farm (docs/aovs.md): workers sum every AOV with the beauty, so the downloaded EXR's
// layers are `lensfarm render`'s bit for bit, in passes and in tiles, with any number of workers.
#include <gtest/gtest.h>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

class AovFarm : public test::FarmFixture {
 protected:
  std::filesystem::path aovScene(const nlohmann::json& tileSize) {
    nlohmann::json scene = nlohmann::json::parse(test::readFile(test::scenesDir() / "cornell-glass-metal.json"));
    scene["render"]["resolution"] = {40, 32};
    scene["render"]["samples_per_pixel"] = 6;
    scene["render"]["samples_per_unit"] = 2;
    scene["render"]["tile_size"] = tileSize;
    scene["render"]["aovs"] = {"albedo", "normal", "depth", "variance", "samples", "object_id", "material_id"};
    for (const char* mesh : {"meshes/cornell-box.obj", "meshes/sphere.obj"})
      dir_.write(mesh, test::readFile(test::scenesDir() / mesh));
    return dir_.write(std::string("aovs-") + (tileSize.is_string() ? "passes" : "tiles") + ".json", scene.dump(2));
  }

  void expectSameLayers(const Image& farm, const Image& local) {
    ASSERT_EQ(farm.layers.size(), 7u);
    ASSERT_EQ(local.layers.size(), farm.layers.size());
    for (const ImageLayer& l : local.layers) {
      const ImageLayer* f = farm.layer(l.name);
      ASSERT_NE(f, nullptr) << l.name;
      EXPECT_EQ(f->channels, l.channels) << l.name;
      EXPECT_TRUE(f->values == l.values) << "layer \"" << l.name << "\" differs from the local render";
    }
  }
};

TEST_F(AovFarm, PassesOnTwoWorkersGiveTheLocalRendersLayersBitForBit) {
  const auto file = aovScene("off");
  const auto [address, job] = renderOnTwoWorkers(file);
  const Image farm = expectFarmImageIsTheLocalRender(address, job, file, "the beauty differs with AOVs on");
  ImageMetadata meta;
  expectSameLayers(farm, renderInProcess(file, &meta));
}

TEST_F(AovFarm, TilesOnTwoWorkersGiveTheLocalRendersLayersBitForBit) {
  const auto file = aovScene(16);
  const auto [address, job] = renderOnTwoWorkers(file);
  const Image farm = expectFarmImageIsTheLocalRender(address, job, file, "the tiled beauty differs with AOVs on");
  ImageMetadata meta;
  expectSameLayers(farm, renderInProcess(file, &meta));
}

TEST_F(AovFarm, DownloadDenoiseIsRenderDenoiseAndNeedsTheGuides) {
  // The job has every AOV; `download --denoise` denoises the farm's EXR on the client: the bits
  // `render --denoise` writes, its raw beauty kept as the layer "noisy".
  const auto file = aovScene("off");
  const auto [address, job] = renderOnTwoWorkers(file);
  const auto farmOut = dir_ / "farm-denoised.exr", localOut = dir_ / "local-denoised.exr";
  const auto d = cli({"download", job, "-o", farmOut.string(), "-o", (dir_ / "farm-denoised.png").string(), "--denoise",
                      "--coordinator", address});
  ASSERT_EQ(d.exitCode, 0) << d.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ / "farm-denoised.png"));
  const auto r = cli({"render", file.string(), "-o", localOut.string(), "--denoise", "-q", "--threads", "2"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ImageMetadata farmMeta, localMeta;
  const Image farm = readExr(farmOut, &farmMeta), local = readExr(localOut, &localMeta);
  EXPECT_TRUE(farm.rgb == local.rgb) << "download --denoise differs from render --denoise";
  EXPECT_EQ(farmMeta.extra["denoised"], localMeta.extra["denoised"]);
  EXPECT_NE(farmMeta.extra["denoised"].find("guided by albedo, normal, variance"), std::string::npos);
  ImageMetadata rawMeta;
  const Image raw = download(address, job, &rawMeta);
  ASSERT_NE(farm.layer("noisy"), nullptr);
  EXPECT_TRUE(farm.layer("noisy")->values == raw.rgb) << "the raw beauty stays available, bit for bit";
  EXPECT_FALSE(farm.rgb == raw.rgb) << "denoising changed nothing";

  // A job without the guides: one clear error naming them, no file.
  nlohmann::json plain = nlohmann::json::parse(test::readFile(file));
  plain["render"].erase("aovs");
  const std::string second = submit(address, dir_.write("plain.json", plain.dump(2)));
  ASSERT_EQ(cli({"watch", second, "--coordinator", address}).exitCode, 0);
  const auto refused =
      cli({"download", second, "-o", (dir_ / "refused.exr").string(), "--denoise", "--coordinator", address});
  EXPECT_EQ(refused.exitCode, 2) << refused.err;
  EXPECT_NE(refused.err.find("albedo, normal, variance"), std::string::npos) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "refused.exr"));
}

TEST_F(AovFarm, AnUnknownAovInASubmissionIsRefusedNamingIt) {
  const auto file = aovScene("off");
  const std::string address = startCoordinator();
  const auto r = cli({"submit", file.string(), "--coordinator", address, "--aov", "albedo,glow"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("\"glow\""), std::string::npos) << r.err;
}

}  // namespace
}  // namespace lensfarm
