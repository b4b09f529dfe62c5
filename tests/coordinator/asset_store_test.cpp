// The coordinator's asset store driven directly (no network): which assets a client still has to
// upload (Coordinator::missingAssets, behind ClientService.FindMissingAssets), the refusal of
// malformed queries by index, and the count of assets sent to workers.
#include <gtest/gtest.h>

#include <fstream>

#include "common/util/error.h"
#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/metrics.h"
#include "tests/deploy_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

const std::string kHello = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";  // sha256 of "hello\n"

// A hash that is well formed and stored nowhere: `digit` repeated.
std::string absent(char digit) { return std::string(64, digit); }

// The message of the FarmError that `body` throws; fails the test if it throws none or another kind.
template <class Body>
std::string refusal(Body&& body) {
  try {
    body();
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no FarmError";
  return "";
}

TEST(AssetStore, MissingAssetsAreThoseNotStoredInTheirOrderEachOnce) {
  Coordinator c;
  EXPECT_TRUE(c.missingAssets({}).empty());
  EXPECT_EQ(c.missingAssets({kHello}), std::vector<std::string>{kHello});
  ASSERT_TRUE(c.putAsset(kHello, "hello\n"));
  EXPECT_TRUE(c.missingAssets({kHello}).empty());
  EXPECT_EQ(c.missingAssets({absent('b'), kHello, absent('a'), absent('b'), kHello}),
            (std::vector<std::string>{absent('b'), absent('a')}));
}

TEST(AssetStore, ARestartedCoordinatorStillHasTheAssetsOfItsStateDir) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  {
    Coordinator c(options);
    ASSERT_TRUE(c.putAsset(kHello, "hello\n"));
  }
  Coordinator restarted(options);
  EXPECT_EQ(restarted.missingAssets({kHello, absent('c')}), std::vector<std::string>{absent('c')});
}

// With a state dir an asset's bytes live on disk: held in memory only while someone uses them,
// shared by everyone using them at once, none loaded by a restart; a file damaged on disk is
// found by its hash, kept aside, and the asset counts as missing until it is uploaded again.
TEST(AssetStore, WithAStateDirAssetsLiveOnDiskAndADamagedOneIsUploadedAgain) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  const std::string big(8 << 20, 'x');
  const std::string sha = sha256Hex(big);
  {
    Coordinator c(options);
    ASSERT_TRUE(c.putAsset(sha, big));
    ASSERT_TRUE(c.putAsset(kHello, "hello\n"));
    EXPECT_EQ(c.metricsSnapshot().assetBytesResident, 0u) << "an upload is not kept in memory";
    {
      const auto first = c.asset(sha), second = c.asset(sha);
      EXPECT_EQ(*first, big);
      EXPECT_EQ(first.get(), second.get()) << "one copy, shared";
      EXPECT_EQ(c.metricsSnapshot().assetBytesResident, big.size());
    }
    EXPECT_EQ(c.metricsSnapshot().assetBytesResident, 0u) << "freed when nobody uses it";
  }
  Coordinator restarted(options);
  EXPECT_EQ(restarted.metricsSnapshot().assetBytesResident, 0u) << "a restart loads no asset";
  EXPECT_TRUE(restarted.missingAssets({sha, kHello}).empty());
  // A bad disk flips a byte of the big one.
  {
    std::fstream f(options.stateDir / "assets" / sha, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(4096);
    f.put('y');
  }
  EXPECT_THROW(restarted.asset(sha), FarmError) << "its bytes no longer hash to its name";
  EXPECT_EQ(restarted.missingAssets({sha, kHello}), std::vector<std::string>{sha}) << "to be uploaded again";
  EXPECT_TRUE(fs::exists(options.stateDir / "lost+found" / ("assets-" + sha))) << "kept aside, not deleted";
  EXPECT_TRUE(restarted.putAsset(sha, big));
  EXPECT_EQ(*restarted.asset(sha), big);
}

TEST(AssetStore, AMalformedHashIsRefusedByItsIndex) {
  Coordinator c;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {std::string(64, 'A'), "upper case"},
      {std::string(63, 'a'), "one digit short"},
      {std::string(65, 'a'), "one digit long"},
      {std::string(63, 'a') + "g", "not hex"},
      {"", "empty"},
      {std::string(63, 'a') + "\n", "a newline"},
  };
  for (const auto& [hash, what] : bad) {
    const std::string message = refusal([&] { c.missingAssets({kHello, absent('1'), hash, absent('2')}); });
    EXPECT_NE(message.find("sha256[2]"), std::string::npos) << what << ": " << message;
    EXPECT_NE(message.find("64 lowercase hex digits"), std::string::npos) << what << ": " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << what << ": control characters are not echoed";
  }
  const std::string longOne = refusal([&] { c.missingAssets({std::string(10000, 'x')}); });
  EXPECT_NE(longOne.find("sha256[0]"), std::string::npos) << longOne;
  EXPECT_LT(longOne.size(), 200u) << "a long bad hash is shortened in the message";
}

TEST(AssetStore, AQueryHoldsAtMostTheLimit) {
  Coordinator c;
  std::vector<std::string> hashes(Coordinator::kMaxAssetQuery, absent('d'));
  EXPECT_EQ(c.missingAssets(hashes).size(), 1u);
  hashes.push_back(absent('e'));
  const std::string message = refusal([&] { c.missingAssets(hashes); });
  EXPECT_NE(message.find("at most " + std::to_string(Coordinator::kMaxAssetQuery)), std::string::npos) << message;
}

TEST(AssetStore, UploadsAreCountedAsStoredOrAlreadyPresent) {
  Coordinator c;
  EXPECT_FALSE(c.uploadFindsAssetPresent(kHello)) << "an upload of a new asset goes on";
  EXPECT_TRUE(c.putAsset(kHello, "hello\n"));
  EXPECT_FALSE(c.putAsset(kHello, "hello\n"));
  EXPECT_TRUE(c.uploadFindsAssetPresent(kHello)) << "an upload of a stored asset can stop at its first message";
  const MetricsSnapshot s = c.metricsSnapshot();
  EXPECT_EQ(s.assetUploadsStored, 1u);
  EXPECT_EQ(s.assetUploadsPresent, 2u);
  EXPECT_EQ(s.assetBytesReceived, 12u) << "two uploads read in full";
  const auto m = test::parseMetrics(renderMetrics(s));
  EXPECT_EQ(m.at("lensfarm_asset_uploads_total{outcome=\"stored\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_asset_uploads_total{outcome=\"present\"}"), 2.0);
}

TEST(AssetStore, AssetsSentToWorkersAreCountedNotThoseTheCoordinatorReadsItself) {
  Coordinator c;
  const std::string obj = test::readFile(test::scenesDir() / "meshes/cube.obj");
  const std::string sha = sha256Hex(obj);
  ASSERT_TRUE(c.putAsset(sha, obj));
  nlohmann::json scene = test::minimalSceneJson();
  scene["shapes"].push_back({{"type", "obj"}, {"file", "cube.obj"}, {"material", "white"}});
  c.submit(JobSpec{"cube.json", scene.dump(), {{"cube.obj", sha}}, {}, std::nullopt}, 0);  // loads the cube itself
  EXPECT_EQ(c.metricsSnapshot().assetsSent, 0u);
  EXPECT_EQ(*c.asset(sha), obj);
  EXPECT_EQ(*c.asset(sha), obj);
  EXPECT_EQ(c.metricsSnapshot().assetsSent, 2u);
  EXPECT_EQ(test::parseMetrics(renderMetrics(c.metricsSnapshot())).at("lensfarm_assets_sent_total"), 2.0);
  EXPECT_THROW(c.asset(absent('f')), FarmError);
}

}  // namespace
}  // namespace lensfarm
