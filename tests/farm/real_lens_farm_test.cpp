// A real-lens job on the farm: the lens file travels as an asset like a
// mesh, every worker traces the same rays through it, and the farm's image equals the in-process
// render bit for bit.
#include <gtest/gtest.h>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

class RealLensFarm : public test::FarmFixture {};

TEST_F(RealLensFarm, AJobThroughTheDoubleGaussIsBitIdenticalToTheLocalRender) {
  nlohmann::json scene = nlohmann::json::parse(test::readFile(test::scenesDir() / "cornell-real-lens.json"));
  scene["render"]["resolution"] = {40, 40};
  scene["render"]["samples_per_pixel"] = 8;
  scene["render"]["samples_per_unit"] = 2;
  dir_.write("meshes/cornell-box.obj", test::readFile(test::scenesDir() / "meshes/cornell-box.obj"));
  dir_.write("lenses/dgauss.50mm.dat", test::readFile(test::scenesDir() / "lenses/dgauss.50mm.dat"));
  const std::filesystem::path file = dir_.write("real-lens.json", scene.dump(2));

  const auto [address, job] = renderOnTwoWorkers(file);
  const Image farm =
      expectFarmImageIsTheLocalRender(address, job, file, "the farm's image differs from the local render");
  double sum = 0.0;
  for (float v : farm.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
  const auto status = cli({"status", job, "--coordinator", address});
  EXPECT_NE(status.out.find("real lens: on"), std::string::npos) << status.out;
  // The double-Gauss's glasses disperse: every camera sample at its own wavelength, on every worker.
  EXPECT_NE(status.out.find("spectral: on"), std::string::npos) << status.out;
}

}  // namespace
}  // namespace lensfarm
