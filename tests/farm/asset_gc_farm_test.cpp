// Assets on real processes (docs/farm.md "Assets"): `lensfarm prefetch` fills a worker's cache
// while the job is still paused, so its units start without a transfer and the image is the
// one-process render's, bit for bit; then the job is archived (its asset kept), deleted (its asset
// collected after --asset-grace, its file gone), and submitted again (the client uploads it anew).
#include <gtest/gtest.h>

#include <chrono>
#include <regex>
#include <thread>

#include "common/util/hash.h"
#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

class AssetGcFarm : public test::FarmFixture {};

TEST_F(AssetGcFarm, PrefetchFillsTheCacheAheadAndADeletedJobsAssetIsCollected) {
  const fs::path state = dir_ / "state";
  const std::string address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string(), "--asset-grace", "1s"});
  const fs::path scene = writeScene(24, 16, 4);
  const std::string mesh = sha256Hex(test::readFile(dir_ / "meshes/cornell-box.obj"));
  const std::string job = submit(address, scene, {"--paused"});
  test::ChildProcess& worker = startWorker(address, "w1");

  // Prefetch: the worker fetches the mesh though no unit is leased (the job is paused).
  const auto prefetched = cli({"prefetch", job, "--coordinator", address});
  ASSERT_EQ(prefetched.exitCode, 0) << prefetched.err;
  EXPECT_TRUE(test::contains(prefetched.out, job + " queued, paused, prefetching")) << prefetched.out;
  ASSERT_TRUE(test::waitFor([&] { return fs::exists(dir_ / "cache-w1" / mesh); }, 60)) << worker.log();
  EXPECT_TRUE(test::contains(worker.log(), "prefetched the 1 asset(s) of " + job)) << worker.log();
  EXPECT_EQ(unitsDone(address, job), 0u) << "still paused";
  EXPECT_EQ(cli({"prefetch", "job-99", "--coordinator", address}).exitCode, 4);

  // Resumed, it renders without fetching again, to the one-process render's bits.
  ASSERT_EQ(cli({"resume", job, "--coordinator", address}).exitCode, 0);
  ASSERT_EQ(cli({"watch", job, "--coordinator", address}).exitCode, 0);
  EXPECT_EQ(count(worker.log(), "fetched asset"), 0u) << worker.log();
  expectFarmImageIsTheLocalRender(address, job, scene, "a prefetched job renders the same image");
  EXPECT_EQ(cli({"prefetch", job, "--coordinator", address}).exitCode, 2) << "it has ended";

  // Archived: its asset stays past the grace.
  ASSERT_EQ(cli({"archive", job, "--coordinator", address}).exitCode, 0);
  const fs::path stored = state / "assets" / mesh;
  ASSERT_TRUE(fs::exists(stored));
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));  // two graces and more: it must stay
  EXPECT_TRUE(fs::exists(stored)) << "an archived job refers to its assets";
  // Deleted: the asset goes within a few checks.
  ASSERT_EQ(cli({"delete", job, "--coordinator", address}).exitCode, 0);
  ASSERT_TRUE(test::waitFor([&] { return !fs::exists(stored); }, 30)) << coordinator_->log();
  EXPECT_TRUE(test::waitFor([&] { return test::contains(coordinator_->log(), "assets: collected 1"); }, 10))
      << coordinator_->log();

  // Submitted again, the client uploads it anew and the farm renders it.
  const auto again = cli({"submit", scene.string(), "--coordinator", address});
  ASSERT_EQ(again.exitCode, 0) << again.err;
  EXPECT_TRUE(test::contains(again.err, "assets: 1 uploaded")) << again.err;
  const std::string second = again.out.substr(0, again.out.find('\n'));
  ASSERT_EQ(cli({"watch", second, "--coordinator", address}).exitCode, 0);
  expectFarmImageIsTheLocalRender(address, second, scene, "after the collection, the same image");
}

}  // namespace
}  // namespace lensfarm
