// Scheduling end to end (docs/farm.md "Scheduling"): a real coordinator and real workers over
// gRPC, driven by the real CLI. Two owners submitting equal jobs at once each get half of the
// farm's samples; a paused job leases nothing, stays paused across a coordinator restart and,
// resumed, ends with the bits of `lensfarm render`; a job that requires tags waits, naming them,
// for a worker started with them; dependencies on another job's error and on an approval; and
// each bad request gets one clear error, queueing nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <regex>

#include "tests/farm/farm_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

constexpr int kNotFoundExit = 4;  // the CLI's exit code for an unknown job (client/exit_codes.h)

class SchedulingFarm : public test::FarmFixture {
 protected:
  test::ChildProcess& startTaggedWorker(const std::string& address, const std::string& name, const std::string& tags) {
    workers_.push_back(std::make_unique<test::ChildProcess>(
        std::vector<std::string>{test::workerPath(), "--coordinator", address, "--threads", "1", "--name", name,
                                 "--tags", tags, "--max-backoff", "0.3"},
        dir_ / ("worker-" + name)));
    return *workers_.back();
  }
  std::string status(const std::string& address, const std::string& job) {
    return cli({"status", job, "--coordinator", address}).out;
  }
  // Waits for the job to end, reading its status every 0.3 s (a light load, the same for every job
  // watched so); `servedFirst`, if given, becomes true if a status said the job was served first.
  bool watchByStatus(const std::string& address, const std::string& job, bool* servedFirst) {
    return test::waitFor(
        [&] {
          const std::string now = status(address, job);
          if (servedFirst) *servedFirst = *servedFirst || test::contains(now, "served first");
          if (test::contains(now, "state:      done") || test::contains(now, "state:      failed")) return true;
          std::this_thread::sleep_for(std::chrono::milliseconds(300));
          return false;
        },
        300);
  }
  bool isDone(const std::string& address, const std::string& job) {
    return test::contains(status(address, job), "state:      done");
  }
};

TEST_F(SchedulingFarm, TwoOwnersSubmittingAtOnceEachGetHalfTheFarm) {
  const fs::path scene = writeScene(64, 32 * 60, 32);  // 60 units each, some 0.1 s apiece
  const std::string address = startCoordinator("127.0.0.1:0", {"--audit-fraction", "0"});
  // Both jobs are queued before any worker calls in: what each gets is the scheduler's choice alone.
  const std::string ann = submit(address, scene, {"--owner", "ann"});
  const std::string bob = submit(address, scene, {"--owner", "bob"});
  startWorker(address, "w1");
  startWorker(address, "w2");
  // Each owner's units done, sampled while both jobs run: the last sample before either ends.
  uint64_t annUnits = 0, bobUnits = 0;
  ASSERT_TRUE(test::waitFor(
      [&] {
        const uint64_t a = unitsDone(address, ann), b = unitsDone(address, bob);
        if (a == 60 || b == 60) return true;
        annUnits = a, bobUnits = b;
        return false;
      },
      600))
      << coordinator_->log();
  ASSERT_GE(annUnits + bobUnits, 30u) << "too few samples while both ran to measure a share";
  const double share = double(annUnits) / double(annUnits + bobUnits);
  std::printf("fair share: ann %llu units, bob %llu units while both ran: ann's share %.3f\n",
              (unsigned long long)annUnits, (unsigned long long)bobUnits, share);
  EXPECT_NEAR(share, 0.5, 0.1) << annUnits << " units of ann's job, " << bobUnits << " of bob's";
  for (const std::string& job : {ann, bob}) ASSERT_TRUE(test::waitFor([&] { return isDone(address, job); }, 300));
  expectFarmImageIsTheLocalRender(address, bob, scene, "a shared job's image is the render's, bit for bit");
}

TEST_F(SchedulingFarm, AJobWithADeadlineMeetsItWhileABigJobRuns) {
  const fs::path scene = writeScene(64, 4096, 4);  // to 3 % error: some seconds on two workers
  const std::string address = startCoordinator("127.0.0.1:0", {"--audit-fraction", "0"});
  startWorker(address, "w1");
  startWorker(address, "w2");
  // How long the whole farm takes to 3 %, alone.
  const auto start = std::chrono::steady_clock::now();
  const std::string probe = submit(address, scene, {"--owner", "bob", "--target-error", "0.03"});
  ASSERT_TRUE(watchByStatus(address, probe, nullptr));
  const double alone = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // ann's big job takes the farm; bob's job then has 1.25x that time: its fair half would take 2x.
  const std::string big = submit(address, writeScene(64, 1 << 20, 4), {"--owner", "ann"});
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, big) >= 4; }, 120));
  const uint64_t bigBefore = unitsDone(address, big);
  const double deadline = 1.25 * alone;
  const std::string bob = submit(
      address, scene, {"--owner", "bob", "--target-error", "0.03", "--deadline", std::to_string(deadline) + "s"});
  // Watched by its status (as the probe was), which says when the coordinator serves it first
  // ("at risk: ...; served first"): only then must the big job have had fewer units (when the
  // machine got quicker than when `alone` was measured, its fair half may do, and is what it gets).
  bool servedFirst = false;
  ASSERT_TRUE(watchByStatus(address, bob, &servedFirst));
  const std::string done = status(address, bob);
  const uint64_t bigDuring = unitsDone(address, big) - bigBefore, bobUnits = unitsDone(address, bob);
  std::printf(
      "deadline share: alone to 3 %% in %.1f s; beside the big job, deadline %.1f s: %s; the big job took %llu "
      "units meanwhile, bob's %llu\n",
      alone, deadline, test::contains(done, "target error reached") ? "target reached" : "missed",
      (unsigned long long)bigDuring, (unsigned long long)bobUnits);
  // The promise: the target is reached before the deadline (1.25x the time alone, where its fair
  // half of the farm would need about 2x: a scheduler without deadlines stops it at the deadline,
  // "stopped: time limit reached").
  EXPECT_TRUE(test::contains(done, "stopped:    target error reached")) << done;
  // Served first whenever its share would not do: never starved below its fair half meanwhile.
  // (How much the big job got depends on when the outlook turned "at risk": measured on 2 cores
  // 0.54 to 0.70 of bob's units when served first from the start, up to 1.19 under a loaded
  // ctest -j2 where it turned late; so only the fair-half floor is asserted.)
  if (servedFirst)
    EXPECT_LE(double(bigDuring), 1.25 * double(bobUnits)) << done;
  else
    std::printf("deadline share: its fair share sufficed (the machine was quicker than when alone was measured)\n");
  ASSERT_EQ(cli({"cancel", big, "--coordinator", address}).exitCode, 0);
}

TEST_F(SchedulingFarm, APausedJobStaysPausedAcrossARestartAndEndsWithTheRendersBits) {
  const fs::path scene = writeScene(24, 1200, 2);  // 600 units, several seconds on one worker
  const fs::path state = dir_ / "state";
  std::string address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string()});
  // Submitted paused: a worker that calls in is leased nothing of it.
  const std::string job = submit(address, scene, {"--paused"});
  startWorker(address, "w1");
  ASSERT_TRUE(test::waitFor(
      [&] {
        return test::contains(cli({"workers", "--coordinator", address}).out, "idle");
      },
      60));
  EXPECT_EQ(unitsDone(address, job), 0u);
  EXPECT_TRUE(test::contains(status(address, job), "paused:     yes"));
  ASSERT_EQ(cli({"resume", job, "--coordinator", address}).exitCode, 0);
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, job) >= 2; }, 120)) << coordinator_->log();
  const auto paused = cli({"pause", job, "--coordinator", address});
  ASSERT_EQ(paused.exitCode, 0) << paused.err;
  EXPECT_EQ(paused.out, job + " running, paused\n");
  // The lease in flight finishes and counts; then nothing more is leased.
  ASSERT_TRUE(test::waitFor(
      [&] {
        return test::contains(status(address, job), "leased until it is resumed (lensfarm resume " + job + ")\n");
      },
      60))
      << status(address, job);
  const uint64_t held = unitsDone(address, job);
  EXPECT_LT(held, 600u);
  const auto workers = cli({"workers", "--coordinator", address});
  EXPECT_TRUE(test::contains(workers.out, "idle")) << workers.out;

  coordinator_.reset();  // a restart: the job is still paused
  workers_.clear();
  address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string()});
  startWorker(address, "w2");
  const std::string after = status(address, job);
  EXPECT_TRUE(test::contains(after, "paused:     yes")) << after;
  EXPECT_EQ(unitsDone(address, job), held);
  const auto resumed = cli({"resume", job, "--coordinator", address});
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  expectFarmImageIsTheLocalRender(address, job, scene, "paused, restarted and resumed: the render's bits");
  const auto late = cli({"pause", job, "--coordinator", address});
  EXPECT_EQ(late.exitCode, test::kBadInput);
  EXPECT_TRUE(test::contains(late.err, job + " has ended (done): there is nothing to pause")) << late.err;
}

TEST_F(SchedulingFarm, TagsDependenciesAndApprovalOverTheCli) {
  const fs::path scene = writeScene(24, 32, 1);  // about 25 % error at the end, 40 % at 13 spp
  const std::string address = startCoordinator("127.0.0.1:0", {"--audit-fraction", "0"});
  startTaggedWorker(address, "plain", "studio-a");
  // Needs a bigmem worker: waits, naming the tags it lacks and what is connected.
  const std::string big = submit(address, scene, {"--require", "bigmem"});
  ASSERT_TRUE(test::waitFor([&] { return test::contains(status(address, big), "tags it requires (bigmem;"); }, 60))
      << status(address, big);
  EXPECT_TRUE(test::contains(status(address, big), "plain (")) << status(address, big);
  // Waits for the first to reach 40 % error, and another for a person's approval.
  const std::string onError = submit(address, scene, {"--after", big + ":error<=40%"});
  const std::string onApproval = submit(address, scene, {"--after", big + ":approved"});
  EXPECT_TRUE(test::contains(status(address, onApproval), "waits for:  " + big + " to be approved"));
  const auto listed = cli({"jobs", "--coordinator", address});
  EXPECT_TRUE(std::regex_search(listed.out, std::regex(onApproval + ".*\\(waiting\\)"))) << listed.out;
  startTaggedWorker(address, "big", "bigmem,studio-b");
  ASSERT_TRUE(test::waitFor(
      [&] {
        return test::contains(cli({"workers", "--coordinator", address}).out, "; tags bigmem,studio-b");
      },
      60))
      << cli({"workers", "--coordinator", address}).out;
  const auto watched = cli({"watch", big, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  ASSERT_TRUE(test::waitFor([&] { return isDone(address, onError); }, 120)) << status(address, onError);
  EXPECT_TRUE(test::contains(status(address, onApproval), "waits for:"));
  const auto approved = cli({"approve", big, "--coordinator", address});
  ASSERT_EQ(approved.exitCode, 0) << approved.err;
  EXPECT_EQ(approved.out, big + " done, approved\n");
  ASSERT_TRUE(test::waitFor([&] { return isDone(address, onApproval); }, 120)) << status(address, onApproval);
  expectFarmImageIsTheLocalRender(address, big, scene, "a tagged job's image is the render's, bit for bit");
}

TEST_F(SchedulingFarm, BadSchedulingRequestsGetOneClearErrorAndQueueNothing) {
  const fs::path scene = writeScene(24, 2, 1);
  const std::string address = startCoordinator();
  const auto refused = [&](std::vector<std::string> flags, int code, const std::string& text) {
    std::vector<std::string> args = {"submit", scene.string(), "--coordinator", address};
    args.insert(args.end(), flags.begin(), flags.end());
    const auto r = cli(args);
    EXPECT_EQ(r.exitCode, code) << r.err;
    EXPECT_TRUE(test::contains(r.err, text)) << r.err;
    const auto errors = test::lines(r.err);
    EXPECT_EQ(
        std::count_if(errors.begin(), errors.end(), [](const std::string& l) { return test::contains(l, "error"); }), 1)
        << r.err;
  };
  refused({"--after", "job-99"}, kNotFoundExit, "after[0]: no job job-99");
  refused({"--after", "job-1:soon"}, test::kBadInput, "unknown condition \"soon\"");
  refused({"--after", "job-1:error<=0%"}, test::kBadInput, "above 0 and at most 100 %");
  refused({"--max-workers", "0"}, test::kBadInput, "--max-workers: 0 workers would never render it");
  refused({"--require", "Big Mem"}, test::kBadInput, "--require: \"Big Mem\": a tag is lower-case letters");
  refused({"--max-unit-failures", "0"}, test::kBadInput, "--max-unit-failures: must be 1 to 1000");
  refused({"--unit-time-limit", "0.01"}, test::kBadInput, "--unit-time-limit: must be 0.1 s to 7 days");
  const auto jobs = cli({"jobs", "--coordinator", address});
  EXPECT_EQ(test::lines(jobs.out).size(), 1u) << "nothing was queued: " << jobs.out;
  const auto badWorker = test::runProcess({test::workerPath(), "--coordinator", address, "--tags", "gpu/a"}, 30);
  EXPECT_EQ(badWorker.exitCode, 2);
  EXPECT_TRUE(test::contains(badWorker.err, "--tags: \"gpu/a\"")) << badWorker.err;
  EXPECT_EQ(cli({"resume", "job-42", "--coordinator", address}).exitCode, kNotFoundExit);
}

}  // namespace
}  // namespace lensfarm
