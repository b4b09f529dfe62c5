// Adaptive sampling on the farm (docs/accuracy.md "Adaptive sampling"): real coordinator and
// worker processes over gRPC. The coordinator allocates each round from the film it summed and
// sends each unit's block map in its lease; the downloaded image is `lensfarm render`'s bit for
// bit, with the samples AOV showing where the samples went.
#include <gtest/gtest.h>

#include <algorithm>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

class AdaptiveFarm : public test::FarmFixture {};

TEST_F(AdaptiveFarm, TwoWorkersGiveTheLocalRendersBitsAndSamplesFollowTheNoise) {
  nlohmann::json scene = nlohmann::json::parse(test::readFile(writeScene(48, 64, 0)));
  scene["render"].erase("samples_per_unit");
  scene["render"]["adaptive"] = {{"block", 8}};
  scene["render"]["aovs"] = {"samples"};
  const auto file = dir_.write("adaptive.json", scene.dump(2));
  const auto [address, job] = renderOnTwoWorkers(file);
  const Image farm =
      expectFarmImageIsTheLocalRender(address, job, file, "the adaptive farm image differs from the local render");
  const ImageLayer* samples = farm.layer("samples");
  ASSERT_NE(samples, nullptr);
  const auto [lo, hi] = std::minmax_element(samples->values.begin(), samples->values.end());
  double mean = 0.0;
  for (float n : samples->values) mean += n;
  mean /= double(samples->values.size());
  EXPECT_NEAR(mean, 64.0, 1.0) << "the job's samples per pixel is the mean";
  EXPECT_GE(*lo, 16.0f + 3.0f * 2.0f) << "the uniform quarter, and the floor of every round";
  EXPECT_GT(*hi, 2.0f * 64.0f) << "the noisiest blocks got more than twice the mean";
}

}  // namespace
}  // namespace lensfarm
