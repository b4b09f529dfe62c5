// Scheduling by policy (coordinator/core/scheduling.cpp, fair_share.h; docs/farm.md "Scheduling"),
// on the plain Coordinator: fair share between owners and jobs, strict priority, tags, caps,
// preferred workers, pause and resume (exactly once), dependencies (done, failed, ended, error,
// approval) and what a restart keeps. The same with real processes: tests/farm/scheduling_farm_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>

#include "common/farm/job_policy.h"
#include "coordinator/core/fair_share.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::kindOf;
using test::resultFor;
using test::workerInfo;

JobSpec smallSpec(uint64_t units) { return test::minimalSpec(units); }

WorkerInfo tagged(const std::string& name, std::vector<std::string> tags) {
  WorkerInfo info = workerInfo(name);
  info.tags = std::move(tags);
  return info;
}

JobPolicy after(const std::string& text, OnDependencyFailure onFailure = OnDependencyFailure::kFail) {
  JobPolicy p;
  p.after.push_back(parseDependency(text, "after"));
  p.onDependencyFailure = onFailure;
  return p;
}

Coordinator::Options noAudit() {
  Coordinator::Options o;
  o.auditFraction = 0.0;  // leases of fresh units alone
  return o;
}

// ---- FairShare alone ----

TEST(FairShare, OwnersWithWorkTakeTurnsInProportionToTheirWeights) {
  FairShare share;
  std::map<std::string, int> leases;
  const std::map<std::string, double> weight = {{"ann", 2.0}, {"bob", 1.0}};
  for (int i = 0; i < 300; ++i) {
    const std::string next = share.ownerStart("ann") <= share.ownerStart("bob") ? "ann" : "bob";
    share.charge(next, weight.at(next), next + "-job", 1.0, 10.0);
    ++leases[next];
  }
  EXPECT_NEAR(leases["ann"], 200, 1);
  EXPECT_NEAR(leases["bob"], 100, 1);
}

TEST(FairShare, AnOwnerAwayBanksNoCredit) {
  FairShare share;
  for (int i = 0; i < 100; ++i) share.charge("ann", 1.0, "a", 1.0, 10.0);  // bob had no work meanwhile
  // bob arrives: from now on the two alternate (bob starts from the last lease's virtual time, one
  // lease ahead), ann is not starved for 100 leases.
  std::map<std::string, int> leases;
  for (int i = 0; i < 20; ++i) {
    const std::string next = share.ownerStart("bob") <= share.ownerStart("ann") ? "bob" : "ann";
    share.charge(next, 1.0, next, 1.0, 10.0);
    ++leases[next];
  }
  EXPECT_NEAR(leases["ann"], 10, 1);
  EXPECT_NEAR(leases["bob"], 10, 1);
}

// ---- the Coordinator ----

// Which owner each of `count` leases by one worker went to (results uploaded at once).
std::map<std::string, int> leasesByOwner(Coordinator& c, const std::string& worker, int count,
                                         const std::map<std::string, std::string>& ownerOfJob) {
  std::map<std::string, int> out;
  for (int i = 0; i < count; ++i) {
    const auto g = c.lease(worker, 0.0);
    if (!g) break;
    ++out[ownerOfJob.at(g->jobId)];
    c.acceptResult(resultFor(worker, *g, 1.0));
  }
  return out;
}

TEST(Scheduling, OwnersOfEqualPriorityShareTheFarmByWeight) {
  Coordinator::Options options = noAudit();
  options.ownerWeights = {{"ann", 3.0}};  // bob weighs 1
  Coordinator c(options);
  std::map<std::string, std::string> owner;
  // ann submits first and twice: a queue would serve both of her jobs before bob's.
  owner[c.submit(smallSpec(40), 0, "ann").id] = "ann";
  owner[c.submit(smallSpec(40), 0, "ann").id] = "ann";
  owner[c.submit(smallSpec(40), 0, "bob").id] = "bob";
  const std::string w = c.registerWorker(workerInfo("w"));
  const auto leases = leasesByOwner(c, w, 40, owner);
  EXPECT_NEAR(leases.at("ann"), 30, 1);
  EXPECT_NEAR(leases.at("bob"), 10, 1);
}

TEST(Scheduling, JobsOfOneOwnerShareByTheirWeights) {
  Coordinator c(noAudit());
  JobPolicy heavy;
  heavy.shareWeight = 3.0;
  const std::string a = c.submit(smallSpec(40), 0, "ann").id;
  const std::string b = c.submit(smallSpec(40), 0, "ann", heavy).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const auto leases = leasesByOwner(c, w, 40, {{a, a}, {b, b}});
  EXPECT_NEAR(leases.at(b), 30, 1);
  EXPECT_NEAR(leases.at(a), 10, 1);
}

TEST(Scheduling, PriorityStaysStrictAndFifoSharingServesInSubmissionOrder) {
  for (const auto sharing : {Coordinator::Options::Sharing::kFairShare, Coordinator::Options::Sharing::kFifo}) {
    Coordinator::Options options = noAudit();
    options.sharing = sharing;
    Coordinator c(options);
    const std::string first = c.submit(smallSpec(3), 0, "ann").id;
    const std::string second = c.submit(smallSpec(3), 0, "bob").id;
    const std::string urgent = c.submit(smallSpec(3), 5, "bob").id;
    const std::string w = c.registerWorker(workerInfo("w"));
    std::vector<std::string> order;
    while (auto g = c.lease(w, 0.0)) order.push_back(g->jobId);
    ASSERT_EQ(order.size(), 9u);
    EXPECT_EQ(std::vector<std::string>(order.begin(), order.begin() + 3), std::vector<std::string>(3, urgent));
    if (sharing == Coordinator::Options::Sharing::kFifo)
      EXPECT_EQ(std::vector<std::string>(order.begin() + 3, order.end()),
                (std::vector<std::string>{first, first, first, second, second, second}));
    else {
      // Shared: bob's urgent job counted towards his share, so ann's job comes first, and the two
      // interleave instead of one finishing before the other starts.
      EXPECT_EQ(order[3], first);
      EXPECT_EQ(std::count(order.begin() + 3, order.end(), first), 3);
      const auto lastOfFirst = std::find(order.rbegin(), order.rend(), first).base() - 1;
      EXPECT_LT(std::find(order.begin() + 3, order.end(), second), lastOfFirst) << "interleaved";
    }
  }
}

TEST(Scheduling, AJobThatRequiresTagsWaitsForAWorkerWithThemAndSaysWhy) {
  Coordinator c(noAudit());
  JobPolicy policy;
  policy.requireTags = {"bigmem", "gpu-a"};
  const std::string job = c.submit(smallSpec(2), 0, "ann", policy).id;
  const std::string plain = c.registerWorker(tagged("plain", {"studio-a"}));
  const std::string half = c.registerWorker(tagged("half", {"bigmem"}));
  EXPECT_FALSE(c.lease(plain, 0.0));
  EXPECT_FALSE(c.lease(half, 0.0));
  const std::string stalled = c.job(job).stalledReason;
  EXPECT_NE(stalled.find("tags it requires (bigmem, gpu-a"), std::string::npos) << stalled;
  EXPECT_NE(stalled.find("plain (" + plain + ") [studio-a]"), std::string::npos) << stalled;
  const std::string big = c.registerWorker(tagged("big", {"gpu-a", "bigmem", "x"}));
  const auto g = c.lease(big, 0.0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, job);
}

TEST(Scheduling, AJobIsRenderedByAtMostItsCapOfWorkers) {
  Coordinator c(noAudit());
  JobPolicy capped;
  capped.maxWorkers = 2;
  const std::string job = c.submit(smallSpec(10), 0, "ann", capped).id;
  const std::string other = c.submit(smallSpec(10), 0, "bob").id;
  const std::string w1 = c.registerWorker(workerInfo("w1")), w2 = c.registerWorker(workerInfo("w2")),
                    w3 = c.registerWorker(workerInfo("w3"));
  std::set<std::string> onJob;
  for (const std::string& w : {w1, w2, w3, w1, w2, w3})
    if (const auto g = c.lease(w, 0.0); g && g->jobId == job) onJob.insert(w);
  EXPECT_EQ(onJob.size(), 2u) << "a third worker must not render the capped job";
  EXPECT_EQ(c.job(other).state, JobState::kRunning) << "the third renders the other job";
}

TEST(Scheduling, OthersTakeAJobThatPrefersTagsOnlyWhileNoPreferredWorkerIsIdle) {
  Coordinator c(noAudit());
  JobPolicy prefers;
  prefers.preferTags = {"fast"};
  const std::string job = c.submit(smallSpec(4), 0, "ann", prefers).id;
  const std::string slow = c.registerWorker(workerInfo("slow"));
  const std::string fast = c.registerWorker(tagged("fast", {"fast"}));
  EXPECT_FALSE(c.lease(slow, 0.0)) << "an idle preferred worker is waiting";
  ASSERT_TRUE(c.lease(fast, 0.0));  // now it is busy
  const auto g = c.lease(slow, 0.0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, job);
}

TEST(Scheduling, APausedJobLeasesNothingAndItsUnitsInFlightCountOnce) {
  Coordinator c(noAudit());
  const std::string job = c.submit(smallSpec(3), 0, "ann").id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const auto g0 = c.lease(w, 0.0);
  ASSERT_TRUE(g0);
  const JobInfo paused = c.pauseJob(job);
  EXPECT_TRUE(paused.paused);
  EXPECT_NE(paused.stalledReason.find("paused"), std::string::npos) << paused.stalledReason;
  EXPECT_FALSE(c.lease(w, 0.0)) << "nothing of a paused job is leased";
  EXPECT_TRUE(c.acceptResult(resultFor(w, *g0, 1.0))) << "the unit in flight counts";
  EXPECT_FALSE(c.acceptResult(resultFor(w, *g0, 1.0))) << "once";
  EXPECT_EQ(c.job(job).unitsDone, 1u);
  EXPECT_TRUE(c.pauseJob(job).paused) << "pausing twice changes nothing";
  EXPECT_FALSE(c.resumeJob(job).paused);
  for (uint64_t expected : {1u, 2u}) {
    const auto g = c.lease(w, 0.0);
    ASSERT_TRUE(g);
    EXPECT_EQ(g->unit.index, expected);
    EXPECT_TRUE(c.acceptResult(resultFor(w, *g, 1.0)));
  }
  const JobInfo done = c.job(job);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.samplesPerPixelDone, 3u);
  EXPECT_EQ(kindOf([&] { c.pauseJob(job); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(kindOf([&] { c.resumeJob("job-404"); }), FarmError::Kind::kNotFound);
}

TEST(Scheduling, AJobWaitsForAnotherToBeDoneAndSaysSo) {
  Coordinator c(noAudit());
  const std::string first = c.submit(smallSpec(2), 0, "ann").id;
  const std::string second = c.submit(smallSpec(2), 5, "ann", after(first)).id;  // higher, yet it waits
  const JobInfo waiting = c.job(second);
  ASSERT_EQ(waiting.waitingFor.size(), 1u);
  EXPECT_EQ(waiting.waitingFor[0], first + " to be done (queued)");
  EXPECT_NE(waiting.stalledReason.find("waiting for " + first), std::string::npos) << waiting.stalledReason;
  const std::string w = c.registerWorker(workerInfo("w"));
  for (int i = 0; i < 2; ++i) {
    const auto g = c.lease(w, 0.0);
    ASSERT_TRUE(g);
    EXPECT_EQ(g->jobId, first);
    c.acceptResult(resultFor(w, *g, 1.0));
  }
  const auto g = c.lease(w, 0.0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, second);
  EXPECT_TRUE(c.job(second).waitingFor.empty());
}

TEST(Scheduling, ADependencyThatCanNoLongerHoldFailsOrHoldsTheJobByItsPolicy) {
  Coordinator c(noAudit());
  const std::string first = c.submit(smallSpec(2), 0, "ann").id;
  const std::string fails = c.submit(smallSpec(2), 0, "ann", after(first)).id;
  const std::string waits = c.submit(smallSpec(2), 0, "ann", after(first, OnDependencyFailure::kWait)).id;
  const std::string onFailure = c.submit(smallSpec(2), 0, "ann", after(first + ":failed")).id;
  const std::string onEnd = c.submit(smallSpec(2), 0, "ann", after(first + ":ended")).id;
  c.cancel(first);
  const std::string w = c.registerWorker(workerInfo("w"));
  const auto g = c.lease(w, 0.0);  // (updates the dependencies)
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, onEnd) << "only the job waiting for any end may start";
  const JobInfo failed = c.job(fails);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_NE(failed.error.find(first + ", which it waits for to be done, cancelled"), std::string::npos) << failed.error;
  EXPECT_EQ(c.job(onFailure).state, JobState::kFailed);
  const JobInfo held = c.job(waits);
  EXPECT_EQ(held.state, JobState::kQueued);
  EXPECT_NE(held.stalledReason.find("can no longer hold"), std::string::npos) << held.stalledReason;
}

TEST(Scheduling, AJobStartsWhenAnotherReachesAnErrorOrIsApproved) {
  Coordinator c(noAudit());
  const std::string preview = c.submit(smallSpec(6), 0, "ann").id;
  const std::string onError = c.submit(smallSpec(2), 0, "ann", after(preview + ":error<=50%")).id;
  const std::string onApproval = c.submit(smallSpec(2), 0, "ann", after(preview + ":approved")).id;
  EXPECT_EQ(c.job(onError).waitingFor[0], preview + " to reach 50 % error (not estimated yet)");
  EXPECT_EQ(c.job(onApproval).waitingFor[0], preview + " to be approved (lensfarm approve " + preview + ")");
  const std::string w = c.registerWorker(workerInfo("w"));
  // Noisy units (alternating sums) until the preview's estimate is known and within 50 %.
  int leased = 0;
  while (c.job(onError).waitingFor.size() == 1 && leased < 6) {
    const auto g = c.lease(w, 0.0);
    ASSERT_TRUE(g);
    ASSERT_EQ(g->jobId, preview);
    c.acceptResult(resultFor(w, *g, g->unit.index % 2 ? 1.0 : 1.2));
    ++leased;
  }
  const JobInfo previewNow = c.job(preview);
  ASSERT_GE(previewNow.estimatedRelativeError, 0.0);
  EXPECT_LE(previewNow.estimatedRelativeError, 0.5);
  c.lease(w, 0.0);  // (a lease call brings the dependencies up to date)
  EXPECT_TRUE(c.job(onError).waitingFor.empty());
  EXPECT_EQ(c.job(onApproval).waitingFor.size(), 1u);
  EXPECT_TRUE(c.approveJob(preview).approved);
  EXPECT_TRUE(c.job(onApproval).waitingFor.empty());
}

TEST(Scheduling, BadPoliciesAreRefusedNamingTheFieldAndQueueNothing) {
  Coordinator c(noAudit());
  const auto refused = [&](JobPolicy p) { return kindOf([&] { c.submit(smallSpec(1), 0, "ann", p); }); };
  EXPECT_EQ(refused(after("job-404")), FarmError::Kind::kNotFound);
  JobPolicy cap;
  cap.maxWorkers = 0;
  EXPECT_EQ(refused(cap), FarmError::Kind::kInvalidArgument);
  for (const std::string& tag : std::vector<std::string>{"Big Mem", "", "-x", "a/b", std::string(65, 'a'), "ü"}) {
    JobPolicy p;
    p.requireTags = {tag};
    EXPECT_EQ(refused(p), FarmError::Kind::kInvalidArgument) << tag;
  }
  JobPolicy weight;
  weight.shareWeight = -1.0;
  EXPECT_EQ(refused(weight), FarmError::Kind::kInvalidArgument);
  EXPECT_TRUE(c.jobs().empty()) << "nothing was queued";
  const std::string first = c.submit(smallSpec(1), 0, "ann").id;
  JobPolicy twice = after(first);
  twice.after.push_back(parseDependency(first + ":ended", "after"));
  EXPECT_EQ(refused(twice), FarmError::Kind::kInvalidArgument);
  try {
    parseDependency("job-3:error<=200%", "--after");
    ADD_FAILURE();
  } catch (const FarmError& e) {
    EXPECT_NE(std::string(e.what()).find("--after: \"job-3:error<=200%\""), std::string::npos) << e.what();
  }
  EXPECT_EQ(kindOf([&] { parseDependency("job-3:soon", "after"); }), FarmError::Kind::kInvalidArgument);
  EXPECT_EQ(parseDependency("job-3:error<=2.5%", "after").maxError, 0.025);
  EXPECT_EQ(dependencyText(parseDependency("job-3:error<=0.025", "after")), "job-3:error<=2.5%");
  EXPECT_EQ(c.jobs().size(), 1u);
}

TEST(Scheduling, AuditsOfAJobGoOnlyToWorkersWithItsAuditTags) {
  Coordinator::Options options;
  options.auditFraction = 1.0;
  Coordinator c(options);
  JobPolicy policy;
  policy.auditRequireTags = {"arm64"};
  const std::string job = c.submit(smallSpec(2), 0, "ann", policy).id;
  const std::string x86 = c.registerWorker(tagged("x86", {"x86-64"}));
  const std::string other = c.registerWorker(tagged("x86-b", {"x86-64"}));
  const std::string arm = c.registerWorker(tagged("arm", {"arm64"}));
  const auto g = c.lease(x86, 0.0);
  ASSERT_TRUE(g);
  ASSERT_TRUE(c.acceptResult(resultFor(x86, *g, 1.0)));
  // Its unit is under audit: not by the other x86 worker (it gets the next fresh unit), by the arm one.
  const auto fresh = c.lease(other, 0.0);
  ASSERT_TRUE(fresh);
  EXPECT_EQ(fresh->unit.index, 1u);
  const auto audit = c.lease(arm, 0.0);
  ASSERT_TRUE(audit);
  EXPECT_EQ(audit->unit.index, 0u) << "the audit of unit 0";
  EXPECT_EQ(c.job(job).auditsPending, 1u);
}

// A job of bob's to a target error of `target` within `deadlineSeconds`, beside a long job of
// ann's, on one worker whose units take `unitSeconds`: which owner each of 12 leases goes to once
// bob's error is known, and bob's outlook.
struct DeadlineRun {
  std::map<std::string, int> leases;
  std::string outlook;
  std::vector<JobInfo::Event> events;
};
DeadlineRun runBesideABigJob(double target, double deadlineSeconds, double unitSeconds) {
  Coordinator c(noAudit());
  const std::string ann = c.submit(test::minimalSpec(1000), 0, "ann").id;
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"]["target_error"] = target;
  scene["render"]["time_limit"] = deadlineSeconds;
  const std::string bob = c.submit(test::specFor(scene, 1000, 1), 0, "bob").id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const auto leaseAndReturn = [&] {
    const auto g = c.lease(w, 0.0);
    EXPECT_TRUE(g);
    // Even and odd units apart by 0.1: an estimated error of about 20 %, far above the targets
    // (film/convergence.h compares the two halves).
    if (g) c.acceptResult(resultFor(w, *g, g->unit.index % 2 ? 0.2 : 0.3, unitSeconds));
    return g ? g->jobId : std::string();
  };
  for (int i = 0; i < 40 && c.job(bob).estimatedRelativeError < 0.0; ++i) leaseAndReturn();
  EXPECT_GE(c.job(bob).estimatedRelativeError, 0.0) << "bob's error is estimated";
  DeadlineRun run;
  for (int i = 0; i < 12; ++i) ++run.leases[leaseAndReturn() == ann ? "ann" : "bob"];
  run.outlook = c.job(bob).deadlineOutlook;
  run.events = c.job(bob).events;
  return run;
}

TEST(Scheduling, AJobThatCannotMeetItsDeadlineOnItsShareIsServedFirstAndSaysSo) {
  // On track: 0.01 % in 4 months at 12 paths a millisecond: its fair share does; the two alternate.
  const DeadlineRun easy = runBesideABigJob(0.0001, 1e7, 0.001);
  EXPECT_EQ(easy.leases.at("ann"), 6);
  EXPECT_EQ(easy.leases.at("bob"), 6);
  EXPECT_EQ(easy.outlook.rfind("on track: about ", 0), 0u) << easy.outlook;
  // 0.01 % in 100 s at 12 paths a second: out of reach even with the whole farm; served first.
  const DeadlineRun hard = runBesideABigJob(0.0001, 100.0, 1.0);
  EXPECT_EQ(hard.leases.count("ann"), 0u);
  EXPECT_EQ(hard.leases.at("bob"), 12);
  EXPECT_EQ(hard.outlook.rfind("out of reach: about ", 0), 0u) << hard.outlook;
  EXPECT_NE(hard.outlook.find("of the farm's 1 worker(s) to reach 0.01 %"), std::string::npos) << hard.outlook;
  ASSERT_FALSE(hard.events.empty());
  EXPECT_EQ(hard.events.back().text.rfind("its target error cannot be met by its deadline", 0), 0u);
}

TEST(Scheduling, AJobsOwnFailureLimitsFailOrPauseItAndResumingTriesAgain) {
  Coordinator c(noAudit());  // the coordinator's limits: 3 workers a unit, 3 failures a worker
  JobPolicy strict;
  strict.maxUnitFailures = 1;
  const std::string failsAtOnce = c.submit(smallSpec(2), 0, "ann", strict).id;
  JobPolicy pausing;
  pausing.maxWorkerFailures = 1;
  pausing.onFailure = OnFailure::kPause;
  const std::string pauses = c.submit(smallSpec(2), 0, "bob", pausing).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  for (int i = 0; i < 2; ++i) {
    const auto g = c.lease(w, 0.0);
    ASSERT_TRUE(g);
    c.reportFailure(w, g->leaseId, g->jobId, "out of disk");
  }
  const JobInfo failed = c.job(failsAtOnce);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_NE(failed.error.find("unit 0 failed on 1 workers: w (" + w + "): out of disk"), std::string::npos)
      << failed.error;
  // One failure blocklists the only worker: the job pauses, keeping its work, instead of failing.
  const JobInfo paused = c.job(pauses);
  EXPECT_EQ(paused.state, JobState::kRunning);
  EXPECT_TRUE(paused.paused);
  EXPECT_NE(paused.events.back().text.find("paused by its failure policy: no worker left"), std::string::npos);
  EXPECT_FALSE(c.lease(w, 0.0));
  c.resumeJob(pauses);  // forgets the failures: the same worker may try again
  const auto again = c.lease(w, 0.0);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->jobId, pauses);
  EXPECT_EQ(again->unit.index, 0u);
}

TEST(Scheduling, AUnitPastItsTimeLimitLapsesAndCountsAsAFailure) {
  Coordinator::Options options = noAudit();
  options.leaseTimeoutSeconds = 60.0;  // heartbeats would keep it for a minute; the limit does not
  Coordinator c(options);
  JobPolicy limited;
  limited.unitTimeLimitSeconds = 0.2;
  limited.maxUnitFailures = 2;
  const std::string job = c.submit(smallSpec(1), 0, "ann", limited).id;
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  for (const std::string& w : {a, b}) {
    const auto g = c.lease(w, 5.0);  // (waits for the unit to come back from the first worker)
    ASSERT_TRUE(g) << w;
    EXPECT_EQ(g->unit.index, 0u);
    ASSERT_TRUE(test::waitFor([&] { return !c.heartbeat(w, {g->leaseId}).empty(); }, 10.0)) << "revoked at its limit";
  }
  const JobInfo failed = c.job(job);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_NE(failed.error.find("unit 0 took longer than its time limit of 0.2 s"), std::string::npos) << failed.error;
}

TEST(Scheduling, PolicyPauseApprovalAndWaitingSurviveARestart) {
  test::TempDir dir;
  Coordinator::Options options = noAudit();
  options.stateDir = dir.path();
  std::string first, second, third;
  {
    Coordinator c(options);
    first = c.submit(smallSpec(2), 0, "ann").id;
    JobPolicy p = after(first + ":approved");
    p.requireTags = {"bigmem"};
    p.maxWorkers = 3;
    second = c.submit(smallSpec(2), 0, "ann", p).id;
    third = c.submit(smallSpec(2), 0, "ann").id;
    c.pauseJob(third);
  }
  {
    Coordinator c(options);
    EXPECT_TRUE(c.job(third).paused);
    const JobInfo waiting = c.job(second);
    EXPECT_EQ(waiting.policy.requireTags, std::vector<std::string>{"bigmem"});
    EXPECT_EQ(waiting.policy.maxWorkers, std::optional<uint32_t>(3));
    ASSERT_EQ(waiting.waitingFor.size(), 1u);
    c.approveJob(first);
    c.cancel(first);  // once released, a job stays released
  }
  Coordinator c(options);
  EXPECT_TRUE(c.job(first).approved);
  EXPECT_TRUE(c.job(second).waitingFor.empty());
  EXPECT_EQ(c.job(second).state, JobState::kQueued);
  const std::string w = c.registerWorker(tagged("big", {"bigmem"}));
  const auto g = c.lease(w, 0.0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, second);
}

}  // namespace
}  // namespace lensfarm
