// The coordinator's rules, driven directly (no network): validation, scheduling order, leases,
// exactly-once and in-order accumulation, cancel, failure, versions.
#include <gtest/gtest.h>

#include <functional>

#include <cstring>
#include <limits>
#include <thread>

#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::resultFor;
using test::workerInfo;

using nlohmann::json;

using test::specFor;

TEST(Coordinator, RefusesBadScenesAndMissingAssets) {
  Coordinator c;
  json bad = test::minimalSceneJson();
  bad["camera"]["focal_lenght"] = 1;
  EXPECT_THROW(c.submit(specFor(bad, 4, 1), 0), InputError);
  JobSpec spec = specFor(test::minimalSceneJson(), 4, 1);
  spec.assets["mesh.obj"] = std::string(64, 'a');
  try {
    c.submit(spec, 0);
    FAIL() << "a job whose asset was never uploaded must be refused";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition);
    EXPECT_NE(std::string(e.what()).find("mesh.obj"), std::string::npos);
  }
  EXPECT_TRUE(c.jobs().empty());
}

TEST(Coordinator, AssetsAreStoredByVerifiedHash) {
  Coordinator c;
  EXPECT_THROW(c.putAsset(std::string(64, '0'), "bytes"), FarmError);
  const std::string sha = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";  // sha256sum of "hello\n"
  EXPECT_TRUE(c.putAsset(sha, "hello\n"));
  EXPECT_FALSE(c.putAsset(sha, "hello\n"));
  EXPECT_EQ(*c.asset(sha), "hello\n");
}

TEST(Coordinator, UnitsAreLeasedInOrderAndJobsByPriorityThenSubmission) {
  Coordinator::Options options;
  options.sharing = Coordinator::Options::Sharing::kFifo;  // (fair share: scheduling_test.cpp)
  Coordinator c(options);
  const std::string low = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0).id;
  const std::string high = c.submit(specFor(test::minimalSceneJson(), 2, 1), 5).id;
  const std::string low2 = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  std::vector<std::pair<std::string, uint64_t>> order;
  while (auto g = c.lease(w, 0.0)) order.emplace_back(g->jobId, g->unit.index);
  const std::vector<std::pair<std::string, uint64_t>> expected = {{high, 0}, {high, 1}, {low, 0},
                                                                  {low, 1},  {low2, 0}, {low2, 1}};
  EXPECT_EQ(order, expected);
  const auto listed = c.jobs();
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(listed[0].id, high);
  EXPECT_EQ(listed[1].id, low);
  EXPECT_EQ(listed[2].id, low2);
}

TEST(Coordinator, ResultsEnterTheSensorOnceAndInUnitOrder) {
  Coordinator::Options options;
  options.auditFraction = 0.0;  // the order of summation alone (audits: audit_test.cpp)
  Coordinator c(options);
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 3, 1), 0);
  EXPECT_EQ(job.state, JobState::kQueued);
  EXPECT_EQ(job.unitsTotal, 3u);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto g0 = c.lease(a, 0), g1 = c.lease(b, 0), g2 = c.lease(a, 0);
  ASSERT_TRUE(g0 && g1 && g2);
  EXPECT_EQ(c.job(job.id).state, JobState::kRunning);
  // Values whose floating-point sum depends on the order (1e16 + 1 + 3, where 1e16's ulp is 2);
  // sums are never negative (Coordinator::checkPlausible).
  EXPECT_TRUE(c.acceptResult(resultFor(a, *g2, 3.0)));
  EXPECT_EQ(c.job(job.id).unitsDone, 0u) << "unit 2 must wait for units 0 and 1";
  EXPECT_EQ(c.image(job.id).metadata.samplesPerPixel, 0u);
  EXPECT_TRUE(c.acceptResult(resultFor(b, *g1, 1.0)));
  EXPECT_FALSE(c.acceptResult(resultFor(b, *g1, 1.0))) << "a duplicate is ignored";
  EXPECT_TRUE(c.acceptResult(resultFor(a, *g0, 1e16)));
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.samplesPerPixelDone, 3u);
  EXPECT_EQ(done.stats.paths, 3u * 12u);
  // In unit order: (1e16 + 1) + 3 with compensation, over 3 samples.
  Sensor reference(4, 3);
  for (double v : {1e16, 1.0, 3.0}) {
    SensorBuffer b2(4, 3);
    std::fill(b2.sums.begin(), b2.sums.end(), v);
    std::fill(b2.samples.begin(), b2.samples.end(), 1u);
    reference.add(b2);
  }
  const Image expected = reference.developImage();
  const JobImage image = c.image(job.id);
  EXPECT_EQ(image.image.rgb, expected.rgb);
  EXPECT_FLOAT_EQ(image.image.rgb[0], float((1e16 + 4.0) / 3.0));
  EXPECT_EQ(image.metadata.samplesPerPixel, 3u);
  EXPECT_EQ(image.metadata.totalSamples, 3u * 12u);
}

TEST(Coordinator, OnlyTheCurrentLeaseHolderCanUpload) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto g = c.lease(a, 0);
  ASSERT_TRUE(g);
  UnitResult forged = resultFor(b, *g, 1.0);
  try {
    c.acceptResult(forged);
    FAIL() << "b does not hold the lease";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition);
  }
  UnitResult poisoned = resultFor(a, *g, 1.0);
  poisoned.buffer.sums[7] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(c.acceptResult(poisoned), FarmError) << "a NaN must never reach the sensor";
  UnitResult wrongSize = resultFor(a, *g, 1.0);
  wrongSize.buffer = SensorBuffer(2, 2);
  EXPECT_THROW(c.acceptResult(wrongSize), FarmError);
  EXPECT_TRUE(c.acceptResult(resultFor(a, *g, 1.0)));
  EXPECT_EQ(c.job(job.id).unitsDone, 1u);
}

TEST(Coordinator, LapsedLeasesGoBackToTheQueue) {
  Coordinator::Options options;
  options.leaseTimeoutSeconds = 0.05;
  Coordinator c(options);
  c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto first = c.lease(a, 0);
  ASSERT_TRUE(first);
  EXPECT_FALSE(c.lease(b, 0)) << "the only unit is leased";
  // b waits; a never heartbeats, so its lease lapses and b gets the unit.
  const auto second = c.lease(b, 5.0);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->unit.index, first->unit.index);
  EXPECT_NE(second->leaseId, first->leaseId);
  EXPECT_THROW(c.acceptResult(resultFor(a, *first, 1.0)), FarmError) << "a's lease is gone";
  EXPECT_EQ(c.heartbeat(a, {first->leaseId}), std::vector<uint64_t>{first->leaseId});
  EXPECT_TRUE(c.acceptResult(resultFor(b, *second, 1.0)));
}

TEST(Coordinator, HeartbeatsKeepLeasesAlive) {
  Coordinator::Options options;
  options.leaseTimeoutSeconds = 0.2;
  Coordinator c(options);
  c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto g = c.lease(a, 0);
  ASSERT_TRUE(g);
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(600)) {
    EXPECT_TRUE(c.heartbeat(a, {g->leaseId}).empty());
    EXPECT_FALSE(c.lease(b, 0.02)) << "a heartbeating worker keeps its unit";
  }
  EXPECT_TRUE(c.acceptResult(resultFor(a, *g, 1.0)));
}

// A worker that heartbeats forever without uploading loses its unit at the longest lease.
TEST(Coordinator, HeartbeatsDoNotKeepALeasePastTheLongestLease) {
  Coordinator::Options options;
  options.leaseTimeoutSeconds = 10.0;
  options.maxLeaseSeconds = 0.3;
  Coordinator c(options);
  c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto g = c.lease(a, 0);
  ASSERT_TRUE(g);
  EXPECT_TRUE(c.heartbeat(a, {g->leaseId}).empty());
  std::optional<LeaseGrant> taken;
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(a, {g->leaseId});  // (on and on)
        taken = c.lease(b, 0.02);
        return taken.has_value();
      },
      10))
      << "the unit never left its squatter";
  EXPECT_EQ(taken->unit.index, g->unit.index);
  EXPECT_EQ(c.heartbeat(a, {g->leaseId}), std::vector<uint64_t>{g->leaseId}) << "a must drop it";
  EXPECT_THROW(c.acceptResult(resultFor(a, *g, 1.0)), FarmError);
  EXPECT_TRUE(c.acceptResult(resultFor(b, *taken, 1.0)));
}

TEST(Coordinator, CancelStopsHandingOutUnitsAndKeepsTheImage) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 4, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a"));
  const auto g0 = c.lease(a, 0), g1 = c.lease(a, 0);
  EXPECT_TRUE(c.acceptResult(resultFor(a, *g0, 2.0)));
  const JobInfo cancelled = c.cancel(job.id);
  EXPECT_EQ(cancelled.state, JobState::kCancelled);
  EXPECT_FALSE(c.lease(a, 0));
  EXPECT_EQ(c.heartbeat(a, {g1->leaseId}), std::vector<uint64_t>{g1->leaseId});
  EXPECT_THROW(c.acceptResult(resultFor(a, *g1, 2.0)), FarmError);
  EXPECT_EQ(c.image(job.id).metadata.samplesPerPixel, 1u);
  EXPECT_FLOAT_EQ(c.image(job.id).image.rgb[5], 2.0f);
  EXPECT_EQ(c.cancel(job.id).state, JobState::kCancelled) << "cancelling twice is harmless";
}

// A failure report ends the lease and queues the unit again for another worker; the job fails,
// with every reason, only once the unit has failed on maxUnitFailures (3) different workers.
TEST(Coordinator, AFailedUnitIsRetriedElsewhereAndTheJobFailsWithEveryReason) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  std::vector<std::string> workers;
  for (const char* name : {"a", "b", "c"}) workers.push_back(c.registerWorker(workerInfo(name)));
  for (size_t k = 0; k < workers.size(); ++k) {
    const auto g = c.lease(workers[k], 0);
    ASSERT_TRUE(g) << "the unit is offered again after " << k << " failure(s)";
    EXPECT_EQ(g->unit.index, 0u);
    c.reportFailure(workers[k], g->leaseId, job.id, "no GPU driver " + std::to_string(k));
    EXPECT_EQ(c.job(job.id).state, k + 1 < workers.size() ? JobState::kRunning : JobState::kFailed);
  }
  const JobInfo failed = c.job(job.id);
  EXPECT_NE(failed.error.find("unit 0 failed on 3 workers"), std::string::npos) << failed.error;
  for (int k = 0; k < 3; ++k) EXPECT_NE(failed.error.find("no GPU driver " + std::to_string(k)), std::string::npos);
}

// A per-machine credential is one worker whatever it does (docs/farm.md "Worker identity"): the
// same attack with three registrations of one credential — each leasing the unit and failing it
// — counts one failing machine, never fails the job while another worker is there, and each new
// registration takes the last one's lease and session away. The honest worker renders the unit.
TEST(Coordinator, ThreeRegistrationsOfOneCredentialCannotFailAJob) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  const std::string honest = c.registerWorker(workerInfo("honest"));
  WorkerInfo sybil = workerInfo("sybil");
  sybil.credential = "render-07";
  std::vector<std::string> ids, sessions;
  for (int k = 0; k < 3; ++k) {
    std::string session;
    sybil.name = "sybil-" + std::to_string(k);
    ids.push_back(c.registerWorker(sybil, &session));
    sessions.push_back(session);
    const auto g = c.lease(ids.back(), 0);
    ASSERT_TRUE(g) << "registration " << k << " is leased the unit";
    c.reportFailure(ids.back(), g->leaseId, job.id, "forged failure " + std::to_string(k));
    EXPECT_EQ(c.job(job.id).state, JobState::kRunning) << "after " << k + 1 << " forged failure(s)";
  }
  EXPECT_EQ(ids[0], ids[1]) << "one credential, one worker id";
  EXPECT_EQ(ids[1], ids[2]);
  EXPECT_NE(sessions[0], sessions[2]);
  EXPECT_EQ(test::kindOf([&] { c.authenticateWorker(ids[0], sessions[0]); }), FarmError::Kind::kPermissionDenied)
      << "a superseded registration's session is refused";
  try {
    c.authenticateWorker(ids[0], sessions[1]);
  } catch (const FarmError& e) {
    EXPECT_NE(std::string(e.what()).find("credential render-07"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(c.authenticateWorker(ids[2], sessions[2]));
  EXPECT_FALSE(c.lease(ids[2], 0)) << "the credential failed the job 3 times: blocklisted for it";
  const auto g = c.lease(honest, 0);
  ASSERT_TRUE(g) << "the honest worker gets the unit";
  EXPECT_TRUE(c.acceptResult(resultFor(honest, *g, 1.0)));
  EXPECT_EQ(c.job(job.id).state, JobState::kDone);
  const std::vector<WorkerView> views = c.workers();
  ASSERT_EQ(views.size(), 2u) << "one line per machine";
  for (const WorkerView& v : views)
    if (v.info.credential == "render-07") {
      EXPECT_EQ(v.registrations, 3u);
      EXPECT_EQ(v.failures, 3u);
    }
}

// A registration of a credential whose worker holds a lease supersedes it: the lease is given
// back (the unit queued again at once) and the earlier registration's upload is refused.
TEST(Coordinator, ANewRegistrationOfACredentialTakesTheLastOnesLease) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  WorkerInfo info = workerInfo("render-01");
  info.credential = "render-01";
  const std::string first = c.registerWorker(info);
  const auto g = c.lease(first, 0);
  ASSERT_TRUE(g);
  const std::string again = c.registerWorker(info);  // the machine restarted
  EXPECT_EQ(again, first);
  EXPECT_EQ(test::kindOf([&] { c.acceptResult(resultFor(first, *g, 1.0)); }), FarmError::Kind::kFailedPrecondition)
      << "the superseded lease's upload does not count";
  const auto h = c.lease(again, 0);
  ASSERT_TRUE(h) << "the unit was queued again at once";
  EXPECT_NE(h->leaseId, g->leaseId);
  EXPECT_TRUE(c.acceptResult(resultFor(again, *h, 1.0)));
  EXPECT_EQ(c.job(job.id).state, JobState::kDone);
}

// A worker that failed a job maxFailuresPerWorker (3) times is not leased it again; when that
// leaves no live worker for the job, it fails at once (a farm of one: `lensfarm render`).
TEST(Coordinator, AWorkerThatKeepsFailingAJobIsBlocklistedForIt) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a"));
  for (int k = 0; k < 3; ++k) {
    const auto g = c.lease(a, 0);
    ASSERT_TRUE(g);
    c.reportFailure(a, g->leaseId, job.id, "scene did not load");
  }
  const JobInfo failed = c.job(job.id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_NE(failed.error.find("no worker left that has not failed it"), std::string::npos) << failed.error;
  EXPECT_NE(failed.error.find("scene did not load"), std::string::npos);
  EXPECT_FALSE(c.lease(a, 0));
  const std::vector<WorkerView> views = c.workers();  // what `lensfarm workers` and the dashboard show
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].failures, 3u);
  EXPECT_EQ(views[0].blocklistedJobs, std::vector<std::string>{job.id});
}

// A report for a lease the worker does not hold, or for another job than the lease's, changes
// nothing (the outside check failed a queued job this way).
TEST(Coordinator, AFailureReportForAnotherWorkersLeaseOrJobChangesNothing) {
  Coordinator c;
  const JobInfo running = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0);
  const JobInfo queued = c.submit(specFor(test::minimalSceneJson(), 2, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a")), b = c.registerWorker(workerInfo("b"));
  const auto g = c.lease(a, 0);
  ASSERT_TRUE(g);
  const auto refused = [&](const std::function<void()>& call, const std::string& part) {
    try {
      call();
      ADD_FAILURE() << "accepted";
    } catch (const FarmError& e) {
      EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition);
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  refused([&] { c.reportFailure(b, g->leaseId, running.id, "forged"); }, "is not held by " + b);
  refused([&] { c.reportFailure(a, g->leaseId, queued.id, "wrong job"); }, "is for " + running.id);
  refused([&] { c.reportFailure(a, g->leaseId + 1, running.id, "no such lease"); }, "is not held by");
  EXPECT_EQ(c.job(running.id).state, JobState::kRunning);
  EXPECT_EQ(c.job(queued.id).state, JobState::kQueued);
  EXPECT_TRUE(c.acceptResult(test::resultFor(a, *g, 1.0))) << "the lease is still a's";
}

TEST(Coordinator, RefusesWorkersOfAnotherVersionNamingBoth) {
  Coordinator c;
  WorkerInfo old = workerInfo("old");
  old.rendererVersion = "lensfarm-renderer/0.0.1";
  try {
    c.registerWorker(old);
    FAIL();
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition);
    EXPECT_NE(std::string(e.what()).find("lensfarm-renderer/0.0.1"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(kRendererVersion), std::string::npos);
  }
  EXPECT_THROW(c.heartbeat("worker-99", {}), FarmError);
}

TEST(Coordinator, WatchersWakeOnChange) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a"));
  std::thread t([&] {
    const auto g = c.lease(a, 0);
    c.acceptResult(resultFor(a, *g, 1.0));
  });
  JobInfo info = job;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (info.state != JobState::kDone && std::chrono::steady_clock::now() < deadline)
    info = c.waitForChange(job.id, info.version, 1.0);
  t.join();
  EXPECT_EQ(info.state, JobState::kDone);
}

TEST(Coordinator, FreshUnitsStayWithinAWindowAheadOfTheSummedPrefix) {
  // Results ahead of a missing unit wait in memory; the window bounds them. 4x3 units are
  // 288 bytes, so a budget of 8 units' worth allows 8 fresh units beyond the prefix.
  Coordinator::Options options;
  options.maxBytesAhead = 8 * 4 * 3 * 3 * sizeof(double);
  Coordinator c(options);
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 100, 1), 0);
  const std::string a = c.registerWorker(workerInfo("a"));
  std::vector<LeaseGrant> grants;
  while (auto g = c.lease(a, 0)) grants.push_back(*g);
  ASSERT_EQ(grants.size(), 8u) << "no unit summed yet: only the window";
  for (size_t k = 1; k < grants.size(); ++k) c.acceptResult(resultFor(a, grants[k], 1.0));
  EXPECT_FALSE(c.lease(a, 0)) << "unit 0 still missing: the window has not moved";
  c.acceptResult(resultFor(a, grants[0], 1.0));
  EXPECT_EQ(c.job(job.id).unitsDone, 8u);
  EXPECT_EQ(c.lease(a, 0)->unit.index, 8u) << "the prefix moved, so does the window";
}

TEST(Coordinator, ReportsTheEffectsItsJobsSimulate) {
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), 1, 1), 0);
  std::string all;
  for (const auto& e : job.effects) all += e + "\n";
  EXPECT_NE(all.find("depth of field: off (aperture closed"), std::string::npos) << all;
  EXPECT_NE(all.find("specular reflection: off (no mirror in the scene)"), std::string::npos) << all;
  EXPECT_NE(c.image(job.id).metadata.extra.at("effects").find("depth of field: off"), std::string::npos);
}

TEST(Coordinator, HugeJobsCostNothingUpFront) {
  // A time-limited render asks for 2^40 samples; the unit queue must be lazy.
  Coordinator c;
  const JobInfo job = c.submit(specFor(test::minimalSceneJson(), uint64_t(1) << 40, 1), 0);
  EXPECT_EQ(job.unitsTotal, uint64_t(1) << 40);
  const std::string a = c.registerWorker(workerInfo("a"));
  EXPECT_EQ(c.lease(a, 0)->unit.index, 0u);
}

}  // namespace
}  // namespace lensfarm
