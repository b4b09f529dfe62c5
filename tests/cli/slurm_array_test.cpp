// What `lensfarm slurm` hands to sbatch and scancel (client/slurm_array.h), without a cluster; the
// real-Slurm end-to-end test is tests/deploy/slurm_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>

#include "client/slurm_array.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm::cli {
namespace {

bool has(const std::vector<std::string>& args, const std::string& arg) {
  return std::find(args.begin(), args.end(), arg) != args.end();
}

TEST(SlurmArray, OneTaskPerWorkerOnItsCoresWithTheSchedulerSettingsAndTheScriptLast) {
  SlurmArray a;
  a.workers = 50;
  a.maxRunning = 10;
  a.cpusPerTask = 8;
  a.timeLimit = "4:00:00";
  a.partition = "render";
  a.account = "vis";
  a.logDir = "/scratch/logs";
  a.script = "/opt/lensfarm/share/lensfarm/slurm/lensfarm-worker.sbatch";
  a.extraSbatchArgs = {"--mem=8G"};
  const auto args = sbatchArguments(a);
  EXPECT_EQ(args.front(), "sbatch");
  EXPECT_TRUE(has(args, "--parsable"));
  EXPECT_TRUE(has(args, "--array=0-49%10")) << "50 tasks, numbered from 0, at most 10 at once";
  EXPECT_TRUE(has(args, "--cpus-per-task=8"));
  EXPECT_TRUE(has(args, "--time=4:00:00"));
  EXPECT_TRUE(has(args, "--partition=render"));
  EXPECT_TRUE(has(args, "--account=vis"));
  EXPECT_TRUE(has(args, "--output=/scratch/logs/lensfarm-worker-%A_%a.log"));
  EXPECT_TRUE(has(args, "--mem=8G"));
  EXPECT_FALSE(has(args, "--qos=")) << "an unset setting is left to the cluster";
  EXPECT_EQ(args.back(), a.script.string()) << "sbatch takes its options before the script";

  a.workers = 1;
  a.maxRunning = 0;
  EXPECT_TRUE(has(sbatchArguments(a), "--array=0-0"));
}

TEST(SlurmArray, SettingsTravelInTheEnvironmentNotInSbatchArguments) {
  SlurmArray a;
  a.coordinator = "farm-host:7878";
  a.workerTokenFile = "/home/u/.lensfarm/worker,token";  // a comma would split --export=
  a.workerBinary = "/opt/lensfarm/bin/lensfarm-worker";
  a.idleExitSeconds = 90;
  const auto env = workerEnvironment(a);
  EXPECT_EQ(env.at("LENSFARM_COORDINATOR"), "farm-host:7878");
  EXPECT_EQ(env.at("LENSFARM_TOKEN_FILE"), "/home/u/.lensfarm/worker,token");
  EXPECT_EQ(env.at("LENSFARM_WORKER"), "/opt/lensfarm/bin/lensfarm-worker");
  EXPECT_EQ(env.at("LENSFARM_IDLE_EXIT"), "90");
  for (const auto& arg : sbatchArguments(a)) EXPECT_EQ(arg.find("--export"), std::string::npos) << arg;

  a.workerTokenFile.clear();
  a.workerBinary.clear();
  EXPECT_EQ(workerEnvironment(a).count("LENSFARM_TOKEN_FILE"), 0u) << "no token file: the worker's own LENSFARM_TOKEN";
  EXPECT_EQ(workerEnvironment(a).count("LENSFARM_WORKER"), 0u) << "no binary: the one on the nodes' PATH";
}

TEST(SlurmArray, TheJobIdOfSbatchParsableOutput) {
  EXPECT_EQ(parseSbatchJobId("1234\n"), "1234");
  EXPECT_EQ(parseSbatchJobId("1234;cluster-a\n"), "1234") << "a federated cluster's name follows a semicolon";
  for (const char* bad : {"", "\n", "Submitted batch job 12\n", "12a\n", ";x\n"})
    EXPECT_THROW(parseSbatchJobId(bad), InputError) << bad;
  EXPECT_EQ(scancelArguments("1234"), (std::vector<std::string>{"scancel", "1234"}));
  EXPECT_TRUE(has(squeueArguments("1234"), "--jobs=1234"));
  EXPECT_TRUE(has(squeueArguments("1234"), "--noheader")) << "no tasks, no output";
}

TEST(SlurmArray, AddressesOnlyThisMachineCanDialAreNoticed) {
  for (const char* local : {"127.0.0.1:7878", "localhost:7878", "[::1]:7878", "0.0.0.0:7878", "127.1.2.3:1", ":7878"})
    EXPECT_TRUE(isLocalOnlyAddress(local)) << local;
  for (const char* remote : {"farm-host:7878", "10.0.0.5:7878", "[fd00::1]:7878", "login01.cluster.edu:443"})
    EXPECT_FALSE(isLocalOnlyAddress(remote)) << remote;
}

// Off a Slurm login node, with a token file that is not there, or no workers: one clear error and
// exit 2, before anything is submitted.
TEST(SlurmCommand, ABadSetUpIsOneClearErrorBeforeAnythingIsSubmitted) {
  const test::TempDir logs;
  const auto r = test::runProcess({"/usr/bin/env", "PATH=/nonexistent", test::cliPath().string(), "slurm", "--workers",
                                   "2", "--coordinator", "farm-host:7878", "--log-dir", logs.path().string()});
  EXPECT_EQ(r.exitCode, test::kBadInput) << r.err;
  EXPECT_TRUE(
      test::contains(r.err, "lensfarm: error: sbatch: No such file or directory (run this on a Slurm login node)"));
  const auto noToken = test::runProcess({test::cliPath().string(), "slurm", "--workers", "2", "--worker-token-file",
                                         (logs / "missing.token").string(), "--log-dir", logs.path().string()});
  EXPECT_EQ(noToken.exitCode, test::kBadInput) << noToken.err;
  EXPECT_TRUE(test::contains(noToken.err, (logs / "missing.token").string())) << "the file is named, on the login node";
  const auto none = test::runProcess({test::cliPath().string(), "slurm", "--workers", "0"});
  EXPECT_EQ(none.exitCode, test::kBadInput) << none.err;
  EXPECT_TRUE(test::contains(none.err, "--workers"));
}

}  // namespace
}  // namespace lensfarm::cli
