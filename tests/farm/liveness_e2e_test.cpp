// Dead workers are seen at once (docs/farm.md "Failures"): a real coordinator with a long lease
// timeout and real worker processes over gRPC. A worker killed with SIGKILL closes its Attach
// stream's connection: the coordinator marks it lost in well under a second, says so in
// `lensfarm workers`, `status` and `watch`, and hands its unit to another worker at once; the
// image is still the in-process render's, bit for bit. A worker stopped cleanly is "left".
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <regex>
#include <sstream>

#include "common/film/image_io.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class FarmLiveness : public ::testing::Test {
 protected:
  void SetUp() override {
    // A lease timeout far longer than anything below may take: only the Attach stream can explain
    // a fast recovery.
    address_ =
        farm_.startCoordinator({"--listen", "127.0.0.1:0", "--heartbeat-interval", "0.2", "--lease-timeout", "60"});
  }
  test::ProcessResult cli(std::vector<std::string> args) {
    args.insert(args.end(), {"--coordinator", address_});
    return farm_.cli(args);
  }
  std::string workers() { return cli({"workers"}).out; }
  uint64_t unitsDone(const std::string& job) {
    const auto r = cli({"status", job});
    std::smatch m;
    if (!std::regex_search(r.out, m, std::regex(R"(\(([0-9]+) / [0-9]+ units)"))) return 0;
    return std::stoull(m[1]);
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  std::string address_;
};

TEST_F(FarmLiveness, AWorkerKilledMidUnitIsLostAtOnceAndItsUnitGoesToAnotherWorker) {
  // 4 units of 2 M paths: over a second each on one thread, so the kill lands inside one.
  const fs::path scene = test::writeSeedScene(dir_, 128, 512, 128);
  test::ChildProcess& doomed = farm_.startWorker("doomed", {"--coordinator", address_, "--threads", "1"});
  const std::string job = farm_.submit({scene.string(), "--coordinator", address_});
  test::ChildProcess watch({test::cliPath().string(), "watch", job, "--coordinator", address_}, dir_ / "watch");

  // Past its first unit (the scene is loaded) and rendering the next one.
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(job) >= 1; }, 120)) << doomed.log();
  ASSERT_TRUE(
      test::waitFor([&] { return test::lineOf(workers(), "doomed").find("s  rendering") != std::string::npos; }, 30))
      << workers();
  doomed.signal(SIGKILL);
  const auto killed = std::chrono::steady_clock::now();
  std::string lost;
  ASSERT_TRUE(test::waitFor(
      [&] {
        lost = test::lineOf(workers(), "doomed");
        return lost.find("s  lost ") != std::string::npos;
      },
      10))
      << "still " << lost << " 10 s after SIGKILL (the lease timeout is 60 s)";
  const double toLost = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  std::printf("kill -9 to \"lost\" in `lensfarm workers`: %.3f s\n", toLost);
  RecordProperty("seconds_from_kill_to_lost", std::to_string(toLost));
  EXPECT_LT(toLost, 5.0);
  EXPECT_NE(lost.find("connection broke"), std::string::npos) << lost;
  EXPECT_NE(lost.find("of " + job + " queued again"), std::string::npos) << "it held a unit: " << lost;
  EXPECT_EQ(doomed.wait(10), -1);

  // Nobody renders the job now, and `status` says why instead of a growing time left.
  const std::string status = cli({"status", job}).out;
  EXPECT_NE(status.find("stalled:    worker doomed (worker-"), std::string::npos) << status;
  EXPECT_NE(status.find("queued again; no workers connected"), std::string::npos) << status;
  EXPECT_NE(status.find("remaining:  stalled"), std::string::npos) << status;

  // Another worker takes the unit at once: the job ends long before the lease would have lapsed.
  farm_.startWorker("survivor", {"--coordinator", address_, "--threads", "1"});
  ASSERT_EQ(watch.wait(120), 0) << watch.log();
  const double toDone = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  EXPECT_LT(toDone, 45.0) << "the lost unit waited for the 60 s lease timeout?";
  const std::string watched = watch.log();
  EXPECT_NE(watched.find(job + ": stalled: worker doomed (worker-"), std::string::npos) << watched;
  EXPECT_NE(watched.find(job + ": rendering again"), std::string::npos) << watched;
  // The watcher was told who went, why, and what is rendered again, as it happened; so is status.
  EXPECT_TRUE(std::regex_search(watched, std::regex(job +
                                                    ": [0-9:-]+ [0-9:]+  worker doomed \\(worker-[0-9.]+\\) lost "
                                                    "\\(connection broke[^)]*\\): units? [0-9, ]+ of " +
                                                    job + " queued again")))
      << watched;
  EXPECT_NE(cli({"status", job}).out.find("worker doomed (worker-"), std::string::npos);

  const fs::path farmExr = dir_ / "farm.exr", localExr = dir_ / "local.exr";
  const auto downloaded = cli({"download", job, "-o", farmExr.string()});
  ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;
  const auto local = farm_.cli({"render", scene.string(), "-o", localExr.string(), "--threads", "2", "-q"});
  ASSERT_EQ(local.exitCode, 0) << local.err;
  ImageMetadata farmMeta, localMeta;
  const Image farmImage = readExr(farmExr, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 128u * 128u * 512u) << "every unit counted exactly once";
  EXPECT_NE(farmMeta.extra["workers"].find("survivor:"), std::string::npos) << farmMeta.extra["workers"];
  EXPECT_EQ(farmImage.rgb, readExr(localExr, &localMeta).rgb) << "the farm's image equals the in-process render";
}

// A worker suspended (SIGSTOP: a laptop lid closed, a VM paused) for longer than its lease, then
// resumed: its unit went to another worker meanwhile; awake, it is told its lease is gone (it
// drops the unit, or its late upload is refused), registers again and carries on serving the
// farm, and the image is still the in-process render's, every unit once.
TEST_F(FarmLiveness, AWorkerSuspendedPastItsLeaseIsRefusedCleanlyWhenItWakes) {
  const fs::path scene = test::writeSeedScene(dir_, 128, 512, 128);
  test::ChildProcess& sleeper = farm_.startWorker("sleeper", {"--coordinator", address_, "--threads", "1"});
  const std::string job = farm_.submit({scene.string(), "--coordinator", address_});
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(job) >= 1; }, 120)) << sleeper.log();
  ASSERT_TRUE(
      test::waitFor([&] { return test::lineOf(workers(), "sleeper").find("s  rendering") != std::string::npos; }, 30))
      << workers();
  sleeper.signal(SIGSTOP);
  // Suspended, it answers no keepalive: lost, its unit queued again, long before the 60 s lease.
  ASSERT_TRUE(
      test::waitFor([&] { return test::lineOf(workers(), "sleeper").find("s  lost ") != std::string::npos; }, 60))
      << workers();
  farm_.startWorker("steady", {"--coordinator", address_, "--threads", "1"});
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(job) >= 2; }, 120)) << "the steady worker took over";
  sleeper.signal(SIGCONT);
  const auto watched = cli({"watch", job});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  EXPECT_TRUE(sleeper.running()) << "waking to a lost lease does not stop the worker: " << sleeper.log();
  // Awake, it learns its lease is gone (the first heartbeat or call): it drops the unit or its
  // upload is refused, and it registers again.
  EXPECT_TRUE(std::regex_search(sleeper.log(), std::regex("abandoned after [0-9.]+ s \\(lease revoked\\)|refused")))
      << sleeper.log();

  const fs::path farmExr = dir_ / "farm.exr", localExr = dir_ / "local.exr";
  ASSERT_EQ(cli({"download", job, "-o", farmExr.string()}).exitCode, 0);
  ASSERT_EQ(farm_.cli({"render", scene.string(), "-o", localExr.string(), "--threads", "2", "-q"}).exitCode, 0);
  ImageMetadata farmMeta, localMeta;
  const Image farmImage = readExr(farmExr, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 128u * 128u * 512u) << "every unit counted exactly once";
  EXPECT_EQ(farmImage.rgb, readExr(localExr, &localMeta).rgb) << "the farm's image equals the in-process render";
}

TEST_F(FarmLiveness, TheWatcherIsToldWhenAWorkerOfTheJobIsLostAndWhenItRejoins) {
  const fs::path scene = test::writeSeedScene(dir_, 128, 512, 128);
  test::ChildProcess& first = farm_.startWorker("w1", {"--coordinator", address_, "--threads", "1"});
  const std::string job = farm_.submit({scene.string(), "--coordinator", address_});
  test::ChildProcess watch({test::cliPath().string(), "watch", job, "--coordinator", address_}, dir_ / "watch");
  ASSERT_TRUE(
      test::waitFor([&] { return test::lineOf(workers(), "w1").find("s  rendering") != std::string::npos; }, 60))
      << workers();
  first.signal(SIGKILL);
  ASSERT_TRUE(test::waitFor([&] { return watch.log().find("worker w1 (worker-") != std::string::npos; }, 20))
      << watch.log();
  EXPECT_NE(watch.log().find(") lost (connection broke"), std::string::npos) << watch.log();
  // The same machine comes back under its name: the job's watchers hear of it.
  farm_.startWorker("w1", {"--coordinator", address_, "--threads", "1"});
  ASSERT_TRUE(test::waitFor([&] { return watch.log().find(") rejoined") != std::string::npos; }, 30)) << watch.log();
  ASSERT_EQ(watch.wait(180), 0) << watch.log();
  const std::string status = cli({"status", job}).out;
  EXPECT_NE(status.find(") rejoined"), std::string::npos) << status;
}

TEST_F(FarmLiveness, AJobWithoutWorkersSaysSoAndAWorkerStoppedCleanlyIsLeftNotLost) {
  const std::string job = farm_.submit({test::writeSeedScene(dir_, 32, 8, 4).string(), "--coordinator", address_});
  std::string status;
  ASSERT_TRUE(test::waitFor(
      [&] {
        status = cli({"status", job}).out;
        return status.find("stalled:    no workers connected") != std::string::npos;
      },
      20))
      << status;

  test::ChildProcess& worker = farm_.startWorker("w", {"--coordinator", address_, "--threads", "1"});
  ASSERT_EQ(cli({"watch", job}).exitCode, 0);
  EXPECT_EQ(cli({"status", job}).out.find("stalled:"), std::string::npos) << "done: nothing to explain";
  ASSERT_TRUE(test::waitFor([&] { return test::lineOf(workers(), "w").find("s  idle") != std::string::npos; }, 30))
      << workers();
  worker.signal(SIGTERM);
  EXPECT_EQ(worker.wait(30), 0) << worker.log();
  const std::string left = test::lineOf(workers(), "w");
  EXPECT_NE(left.find("s  left "), std::string::npos) << left;
  EXPECT_NE(left.find("stopped"), std::string::npos) << left;
  EXPECT_EQ(left.find("lost"), std::string::npos) << left;
}

}  // namespace
}  // namespace lensfarm
