// The job life cycle end to end (docs/farm.md "Job life cycle"): a real coordinator with a state
// dir and a real worker over gRPC, driven by the real CLI: jobs archived as they end (the
// default) still download bit for bit, `lensfarm jobs` filters, `lensfarm delete` removes a job
// and its files for good (also across a restart), and each bad request gets one clear error.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/farm/farm_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class JobLifecycleFarm : public test::FarmFixture {};

TEST_F(JobLifecycleFarm, ArchiveFilterAndDeleteOverTheCli) {
  const fs::path scene = writeScene(24, 4, 2);  // 2 units
  const fs::path state = dir_ / "state";
  std::string address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string()});
  startWorker(address, "w1");
  const std::string alices = submit(address, scene, {"--owner", "alice"});
  const std::string bobs = submit(address, scene, {"--owner", "bob"});
  for (const std::string& job : {alices, bobs}) {
    const auto watched = cli({"watch", job, "--coordinator", address});
    ASSERT_EQ(watched.exitCode, 0) << watched.err << coordinator_->log();
  }
  // Archived as it ended (the coordinator's default, --archive-after 0): the image is kept.
  ASSERT_TRUE(test::waitFor([&] { return fs::exists(state / "jobs" / alices / "final.exr"); }, 30))
      << coordinator_->log();
  const auto status = cli({"status", alices, "--coordinator", address});
  EXPECT_TRUE(test::contains(status.out, "owner:      alice"));
  EXPECT_TRUE(test::contains(status.out, "archived:   yes"));
  EXPECT_TRUE(test::waitFor([&] { return !fs::exists(state / "jobs" / alices / "sensor.bin"); }, 30));
  expectFarmImageIsTheLocalRender(address, alices, scene, "an archived job's image is the render's, bit for bit");
  const auto again = cli({"archive", alices, "--coordinator", address});
  EXPECT_EQ(again.exitCode, 0) << again.err;

  // A job no worker can take stays queued: it can be neither archived nor deleted without --force.
  workers_.clear();  // the worker is killed
  const std::string queued = submit(address, scene, {"--owner", "alice"});
  const auto archiveQueued = cli({"archive", queued, "--coordinator", address});
  EXPECT_EQ(archiveQueued.exitCode, test::kBadInput);
  EXPECT_TRUE(test::contains(archiveQueued.err, queued + " is queued: only a job that ended can be archived"));
  const auto deleteQueued = cli({"delete", queued, "--coordinator", address});
  EXPECT_EQ(deleteQueued.exitCode, test::kBadInput);
  EXPECT_TRUE(test::contains(deleteQueued.err, "cancel it first, or delete it with --force"));

  // Filters: by owner, state, scene name and count; the alias `jobs`.
  const auto byOwner = cli({"jobs", "--owner", "alice", "--coordinator", address});
  ASSERT_EQ(byOwner.exitCode, 0) << byOwner.err;
  EXPECT_TRUE(test::contains(byOwner.out, alices));
  EXPECT_TRUE(test::contains(byOwner.out, queued));
  EXPECT_FALSE(test::contains(byOwner.out, bobs));
  const auto byState = cli({"jobs", "--state", "done", "--limit", "1", "--coordinator", address});
  EXPECT_EQ(test::lines(byState.out).size(), 2u) << byState.out;  // the header and one job
  EXPECT_TRUE(test::contains(byState.out, alices));
  const auto byName = cli({"jobs", "--name", "no-such-scene", "--coordinator", address});
  EXPECT_EQ(test::lines(byName.out).size(), 1u) << byName.out;
  const auto badState = cli({"jobs", "--state", "finished", "--coordinator", address});
  EXPECT_EQ(badState.exitCode, test::kBadInput);

  // Deleting: several at once, --force for the queued one; then gone, with its files.
  const auto deleted = cli({"delete", alices, queued, "--force", "--coordinator", address});
  ASSERT_EQ(deleted.exitCode, 0) << deleted.err;
  EXPECT_FALSE(fs::exists(state / "jobs" / alices));
  EXPECT_EQ(cli({"status", alices, "--coordinator", address}).exitCode, 4);
  const auto twice = cli({"delete", alices, "--coordinator", address});
  EXPECT_EQ(twice.exitCode, 4);
  EXPECT_TRUE(test::contains(twice.err, "no job " + alices));

  // A restart on the same state dir does not bring it back.
  coordinator_.reset();
  address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string()});
  EXPECT_EQ(cli({"status", alices, "--coordinator", address}).exitCode, 4);
  const auto listed = cli({"jobs", "--coordinator", address});
  EXPECT_FALSE(test::contains(listed.out, alices));
  EXPECT_TRUE(test::contains(listed.out, bobs));
  EXPECT_TRUE(test::contains(listed.out, "(archived)"));
}

TEST_F(JobLifecycleFarm, BadDurationsStopTheCoordinatorWithOneClearError) {
  for (const auto& [flag, message] : std::vector<std::pair<std::string, std::string>>{
           {"--keep=7x", "--keep: expected a duration such as 7d"},
           {"--keep=-1d", "--keep: a duration cannot be negative"},
           {"--archive-after=soon", "--archive-after: expected a duration such as 7d"}}) {
    const auto r = test::runProcess({test::coordinatorPath().string(), "--listen", "127.0.0.1:0", flag}, 30);
    EXPECT_EQ(r.exitCode, test::kBadInput) << flag;
    EXPECT_TRUE(test::contains(r.out + r.err, message)) << flag;
  }
}

}  // namespace
}  // namespace lensfarm
