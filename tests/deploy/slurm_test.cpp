// Workers on a real Slurm (deploy/slurm/README.md): Debian's slurm-wlm with munge,
// slurmctld and slurmd started here (tests/support/local_slurm.h), a real coordinator, and the
// workers started by `lensfarm slurm` as a job array through deploy/slurm/lensfarm-worker.sbatch.
// One task is cancelled with scancel in the middle of a unit: it gives its lease back at once and
// leaves (shown as left, not lost), and the image is still the in-process render's, bit for bit,
// with every sample counted once. When the job ends the command cancels the array. The coordinator
// as a Slurm job is found by workers through the address file it writes, and idle workers leave
// by themselves.
//
// The log of each test shows the sbatch job ids and the squeue states it saw.
#include <gtest/gtest.h>

#include <csignal>
#include <map>
#include <sstream>

#include "common/film/image_io.h"
#include "tests/deploy_support.h"
#include "tests/support/local_slurm.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::string joined(const std::vector<std::string>& rows) {
  std::string text;
  for (const auto& r : rows) text += (text.empty() ? "" : ", ") + r;
  return text.empty() ? "(none)" : text;
}

class Slurm : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const auto reason = test::LocalSlurm::unavailableReason()) {
      // scripts/setup.sh installs Slurm wherever apt-get can: there, a missing binary is a failure.
      if (fs::exists("/etc/debian_version")) FAIL() << *reason;
      GTEST_SKIP() << *reason;
    }
    slurm_ = std::make_unique<test::LocalSlurm>(dir_ / "slurm");
    ::setenv("SLURM_CONF", (dir_ / "slurm/slurm.conf").c_str(), 1);  // for `lensfarm slurm`'s sbatch
    std::printf("slurm: %s\n", slurm_->run({"sinfo", "-h", "-o", "%P %D %c %T"}).out.c_str());
  }
  void TearDown() override {
    farm_.reset();   // the coordinator, before Slurm's jobs are cancelled
    slurm_.reset();  // cancels every job, waits for them, stops the daemons
  }
  // squeue's tasks of `job`, printed for the log when they change.
  std::vector<std::string> tasks(const std::string& job) {
    const auto rows = slurm_->tasks(job);
    if (rows != lastTasks_[job]) std::printf("squeue -r -j %s: %s\n", job.c_str(), joined(rows).c_str());
    lastTasks_[job] = rows;
    return rows;
  }
  // sbatch --parsable with `variables` (NAME=VALUE) in its environment; the job id.
  std::string sbatch(const std::vector<std::string>& variables, const std::vector<std::string>& args) {
    std::vector<std::string> argv = variables;
    argv.push_back("sbatch");
    argv.push_back("--parsable");
    argv.insert(argv.end(), args.begin(), args.end());
    const auto r = slurm_->run(argv);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    const std::string id = r.out.substr(0, r.out.find_first_of(";\n"));
    std::printf("sbatch %s: job id %s\n", args.back().c_str(), id.c_str());
    return id;
  }
  test::ProcessResult cli(std::vector<std::string> args, const std::vector<std::string>& connection) {
    args.insert(args.end(), connection.begin(), connection.end());
    return farm_->cli(args);
  }
  std::string workers(const std::string& address) { return farm_->cli({"workers", "--coordinator", address}).out; }

  test::TempDir dir_;
  std::unique_ptr<test::LocalSlurm> slurm_;
  std::map<std::string, std::vector<std::string>> lastTasks_;
  std::unique_ptr<test::FarmProcesses> farm_ = std::make_unique<test::FarmProcesses>(dir_);
};

TEST_F(Slurm, AWorkerArrayRendersTheLocalImageAndAScancelledTaskLosesNothing) {
  // A lease timeout far longer than the test: a unit comes back quickly only if the cancelled
  // worker gives it back.
  const std::string address = farm_->startCoordinator({"--listen", "127.0.0.1:0", "--lease-timeout", "600"});
  const fs::path scene = test::writeSeedScene(dir_, 128, 4096, 256);  // 16 units of ~4 M paths
  const std::string job = farm_->submit({scene.string(), "--coordinator", address});

  const fs::path logs = dir_ / "worker-logs";
  test::ChildProcess helper(
      {test::cliPath().string(), "slurm", job, "--coordinator", address, "--workers", "3", "--cpus-per-task", "1",
       "--log-dir", logs.string(), "--worker-binary", test::workerPath().string(), "--idle-exit", "120"},
      dir_ / "slurm-helper");
  std::string array;
  ASSERT_TRUE(test::waitFor(
      [&] {
        array = test::readFile(dir_ / "slurm-helper.stdout");
        return array.find('\n') != std::string::npos;
      },
      60))
      << helper.log() << slurm_->logs();
  array = array.substr(0, array.find('\n'));
  std::printf("sbatch job id: %s\n", array.c_str());
  ASSERT_FALSE(array.empty());
  EXPECT_TRUE(test::contains(helper.log(), "submitted 3 workers as Slurm job " + array));

  // The three tasks run, each a worker named after its array task.
  const std::vector<std::string> running = {array + "_0 RUNNING", array + "_1 RUNNING", array + "_2 RUNNING"};
  ASSERT_TRUE(test::waitFor([&] { return tasks(array) == running; }, 60)) << slurm_->logs();
  const std::string victim = "slurm-" + array + "_1";
  ASSERT_TRUE(
      test::waitFor([&] { return test::lineOf(workers(address), victim).find(" rendering") != std::string::npos; }, 60))
      << workers(address) << test::readFile(logs / ("lensfarm-worker-" + array + "_1.log"));

  // scancel of one task while it renders a unit: Slurm sends SIGTERM; the worker gives the lease
  // back and leaves at once.
  const auto cancelled = slurm_->run({"scancel", array + "_1"});
  ASSERT_EQ(cancelled.exitCode, 0) << cancelled.err;
  std::printf("scancel %s_1\n", array.c_str());
  ASSERT_TRUE(test::waitFor([&] { return tasks(array).size() == 2; }, 30));
  const std::string victimLog = test::readFile(logs / ("lensfarm-worker-" + array + "_1.log"));
  EXPECT_TRUE(test::contains(victimLog, "SIGTERM: giving the current unit back and leaving"));
  EXPECT_TRUE(test::contains(victimLog, "abandoned after")) << "it was cancelled in the middle of a unit";
  EXPECT_TRUE(test::contains(victimLog, "stopped after"));
  const std::string left = test::lineOf(workers(address), victim);
  EXPECT_TRUE(test::contains(left, " left ")) << "a clean exit, not a lost worker";
  EXPECT_EQ(left.find("lost"), std::string::npos) << left;

  // The helper sees the job end and cancels the rest of the array.
  ASSERT_EQ(helper.wait(300), 0) << helper.log();
  EXPECT_TRUE(test::contains(helper.log(), job + " done"));
  EXPECT_TRUE(test::contains(helper.log(), "cancelled Slurm job " + array));
  EXPECT_TRUE(test::waitFor([&] { return tasks(array).empty(); }, 60)) << "no worker outlives the job";

  const fs::path farmExr = dir_ / "farm.exr", localExr = dir_ / "local.exr";
  const auto downloaded = farm_->cli({"download", job, "--coordinator", address, "-o", farmExr.string()});
  ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;
  const auto local = farm_->cli({"render", scene.string(), "-o", localExr.string(), "--threads", "2", "-q"});
  ASSERT_EQ(local.exitCode, 0) << local.err;
  ImageMetadata farmMeta, localMeta;
  const Image farmImage = readExr(farmExr, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 128u * 128u * 4096u) << "every sample counted exactly once";
  EXPECT_EQ(farmImage.rgb, readExr(localExr, &localMeta).rgb) << "the farm's image equals the in-process render";
  for (const char* task : {"_0", "_2"})
    EXPECT_TRUE(test::contains(farmMeta.extra["workers"], "slurm-" + array + task)) << "every running task rendered";
}

TEST_F(Slurm, TheCoordinatorAsASlurmJobIsFoundByWorkersThatLeaveWhenIdle) {
  const fs::path slurmDir = test::sourceDir() / "deploy/slurm", addressFile = dir_ / "shared/coordinator";
  const std::string coordinatorJob =
      sbatch({"LENSFARM_COORDINATOR_FILE=" + addressFile.string(), "LENSFARM_STATE_DIR=" + (dir_ / "state").string(),
              "LENSFARM_ADVERTISE=127.0.0.1", "LENSFARM_COORDINATOR_BIN=" + test::coordinatorPath().string()},
             {"--output=" + (dir_ / "coordinator.log").string(), (slurmDir / "lensfarm-coordinator.sbatch").string()});
  ASSERT_TRUE(test::waitFor([&] { return fs::exists(addressFile); }, 60))
      << test::readFile(dir_ / "coordinator.log") << slurm_->logs();
  const std::string address = test::lines(test::readFile(addressFile)).at(0);
  EXPECT_EQ(address.rfind("127.0.0.1:", 0), 0u) << address;

  // The coordinator job made the farm's tokens beside its address file.
  const std::vector<std::string> client = {"--coordinator", address, "--token-file",
                                           (dir_ / "shared/client.token").string()};
  EXPECT_EQ(fs::status(dir_ / "shared/worker.token").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  const auto without = farm_->cli({"status", "--coordinator", address});
  EXPECT_EQ(without.exitCode, 6) << "no token, no answer: " << without.err;
  // A request Slurm refuses: sbatch's own message, exit 1, and nothing queued.
  const auto refused =
      cli({"slurm", "--workers", "2", "--partition", "nosuch", "--log-dir", (dir_ / "l").string()}, client);
  EXPECT_EQ(refused.exitCode, 1) << refused.err;
  EXPECT_TRUE(test::contains(refused.err, "invalid partition"));
  EXPECT_TRUE(test::contains(refused.err, "lensfarm: error: sbatch refused the worker array (exit 1)"));
  EXPECT_EQ(slurm_->run({"squeue", "-h", "-o", "%i"}).out, coordinatorJob + "\n") << "only the coordinator's job";

  // Workers that all end before the job does (here a scancel by hand; a time limit alike): the
  // command says so and exits 5 instead of waiting for ever.
  const std::string big = farm_->submit([&] {
    std::vector<std::string> a = {test::writeSeedScene(dir_, 256, 1 << 20, 64).string()};
    a.insert(a.end(), client.begin(), client.end());
    return a;
  }());
  test::ChildProcess orphaned(
      [&] {
        std::vector<std::string> a = {test::cliPath().string(),
                                      "slurm",
                                      big,
                                      "--workers",
                                      "1",
                                      "--cpus-per-task",
                                      "1",
                                      "--log-dir",
                                      (dir_ / "l").string(),
                                      "--worker-binary",
                                      test::workerPath().string(),
                                      "--worker-token-file",
                                      (dir_ / "shared/worker.token").string()};
        a.insert(a.end(), client.begin(), client.end());
        return a;
      }(),
      dir_ / "orphaned");
  std::string orphanArray;
  ASSERT_TRUE(test::waitFor([&] { return !(orphanArray = test::readFile(dir_ / "orphaned.stdout")).empty(); }, 30));
  orphanArray = orphanArray.substr(0, orphanArray.find('\n'));
  ASSERT_EQ(slurm_->run({"scancel", orphanArray}).exitCode, 0);
  EXPECT_EQ(orphaned.wait(60), 5) << orphaned.log();
  EXPECT_TRUE(test::contains(orphaned.log(), "every worker of Slurm job " + orphanArray + " has ended"));
  ASSERT_EQ(cli({"cancel", big}, client).exitCode, 0);

  const fs::path scene = test::writeSeedScene(dir_, 48, 64, 8);
  std::vector<std::string> submit = {scene.string()};
  submit.insert(submit.end(), client.begin(), client.end());
  const std::string job = farm_->submit(submit);

  // Workers find the coordinator through the file, render the job, and leave 3 s after it ends.
  const std::string array =
      sbatch({"LENSFARM_COORDINATOR_FILE=" + addressFile.string(), "LENSFARM_IDLE_EXIT=3",
              "LENSFARM_WORKER=" + test::workerPath().string(), "LENSFARM_CACHE_DIR=" + (dir_ / "cache").string()},
             {"--array=0-1", "--cpus-per-task=1", "--output=" + (dir_ / "worker-%A_%a.log").string(),
              (slurmDir / "lensfarm-worker.sbatch").string()});
  const auto watched = cli({"watch", job}, client);
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  ASSERT_TRUE(test::waitFor([&] { return tasks(array).empty(); }, 60)) << "idle workers leave by themselves";
  for (const char* task : {"_0", "_1"}) {
    const std::string log = test::readFile(dir_ / ("worker-" + array + task + ".log"));
    EXPECT_TRUE(test::contains(log, "coordinator " + address));
    EXPECT_TRUE(test::contains(log, "(--idle-exit): leaving"));
    EXPECT_TRUE(test::contains(test::lineOf(cli({"workers"}, client).out, "slurm-" + array + task), " left "));
  }
  ImageMetadata meta;
  const fs::path exr = dir_ / "farm.exr";
  ASSERT_EQ(cli({"download", job, "-o", exr.string()}, client).exitCode, 0);
  readExr(exr, &meta);
  EXPECT_EQ(meta.totalSamples, 48u * 48u * 64u);

  // scancel: the coordinator saves its jobs and stops; its address file goes with it.
  ASSERT_EQ(slurm_->run({"scancel", coordinatorJob}).exitCode, 0);
  ASSERT_TRUE(test::waitFor([&] { return tasks(coordinatorJob).empty(); }, 60));
  EXPECT_FALSE(fs::exists(addressFile)) << test::readFile(dir_ / "coordinator.log");
  EXPECT_TRUE(fs::exists(dir_ / "state")) << "the state stays for the next coordinator job";
}

}  // namespace
}  // namespace lensfarm
