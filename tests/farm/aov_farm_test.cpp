// AOVs on the farm (docs/aovs.md): workers sum every AOV with the beauty, so the downloaded EXR's
// layers are `lensfarm render`'s bit for bit, in passes and in tiles, with any number of workers.
#include <gtest/gtest.h>

#include "farm/farm_fixture.h"

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

TEST_F(AovFarm, AnUnknownAovInASubmissionIsRefusedNamingIt) {
  const auto file = aovScene("off");
  const std::string address = startCoordinator();
  const auto r = cli({"submit", file.string(), "--coordinator", address, "--aov", "albedo,glow"});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("\"glow\""), std::string::npos) << r.err;
}

}  // namespace
}  // namespace lensfarm
