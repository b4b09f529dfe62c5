// A job with diffraction on the farm (docs/optics.md "Diffraction"): the coordinator applies the
// aperture's point-spread function where it develops the image, so the farm's download is
// `lensfarm render`'s image bit for bit, and both differ from the same scene without it.
#include <gtest/gtest.h>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

class DiffractionFarm : public test::FarmFixture {};

TEST_F(DiffractionFarm, AStarburstJobIsBitIdenticalToTheLocalRender) {
  nlohmann::json scene = nlohmann::json::parse(test::readFile(test::scenesDir() / "night-lights-starburst.json"));
  scene["render"]["resolution"] = {64, 40};
  scene["render"]["samples_per_pixel"] = 4;
  scene["render"]["samples_per_unit"] = 2;
  scene["camera"]["diffraction"]["scene_units_per_mm"] = 0.01;  // the 64 px sensor's cells at the scene's Airy radius
  const std::filesystem::path file = dir_.write("starburst.json", scene.dump(2));

  const auto [address, job] = renderOnTwoWorkers(file);
  const Image farm =
      expectFarmImageIsTheLocalRender(address, job, file, "the farm's image differs from the local render");
  const auto status = cli({"status", job, "--coordinator", address});
  EXPECT_NE(status.out.find("diffraction: on"), std::string::npos) << status.out;

  scene["camera"]["diffraction"] = false;
  ImageMetadata meta;
  const Image plain = renderInProcess(dir_.write("plain.json", scene.dump(2)), &meta);
  ASSERT_EQ(plain.rgb.size(), farm.rgb.size());
  EXPECT_NE(plain.rgb, farm.rgb) << "diffraction changes the local render too";
  double sumPlain = 0.0, sumFarm = 0.0;
  for (size_t k = 0; k < farm.rgb.size(); ++k) sumPlain += plain.rgb[k], sumFarm += farm.rgb[k];
  EXPECT_GT(sumPlain, 0.0);
  EXPECT_LT(sumFarm, sumPlain * (1.0 + 1e-4)) << "the PSF spreads light; it never adds any";
}

}  // namespace
}  // namespace lensfarm
