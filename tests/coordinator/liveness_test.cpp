// Workers that vanish (docs/farm.md "Failures"): Coordinator::workerLost, driven directly (no
// network), as the Attach stream's end calls it. A lost worker's units go back to the queue at
// once, each is still counted once, a late upload under a revoked lease is refused, the lost
// worker stays listed with why, and a job nobody renders says why it is stalled. Also the
// dashboard's progress toward a target error or a deadline when the job has no sample cap.
#include <gtest/gtest.h>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/metrics.h"
#include "coordinator/web/dashboard.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::workerInfo;

using nlohmann::json;

JobSpec specFor(uint64_t spp, double targetError = 0.0, double timeLimit = 0.0) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {4, 3};
  if (targetError > 0) scene["render"]["target_error"] = targetError;
  if (timeLimit > 0) scene["render"]["time_limit"] = timeLimit;
  JobSpec spec;
  spec.sceneName = "test.json";
  spec.sceneJson = scene.dump();
  return spec;
}

UnitResult resultFor(const std::string& worker, const LeaseGrant& g, double value) {
  return test::resultFor(worker, g, value, 0.1);
}

WorkerView viewOf(const Coordinator& c, const std::string& id) {
  for (const WorkerView& w : c.workers())
    if (w.id == id) return w;
  ADD_FAILURE() << "no worker " << id;
  return {};
}

using test::kindOf;

Coordinator::Options longLeases() {
  Coordinator::Options o;
  o.leaseTimeoutSeconds = 60.0;  // nothing here may wait for a lease to lapse
  return o;
}

TEST(Liveness, ALostWorkersUnitIsLeasedAgainOnceAndItsLateUploadIsRefused) {
  Coordinator c(longLeases());
  const std::string job = c.submit(specFor(4), 0).id;
  const std::string doomed = c.registerWorker(workerInfo("doomed"));
  const uint64_t stream = c.attachWorker(doomed);
  const auto held = c.lease(doomed, 0);
  ASSERT_TRUE(held);
  ASSERT_EQ(held->unit.index, 0u);
  const std::string survivor = c.registerWorker(workerInfo("survivor"));
  EXPECT_EQ(viewOf(c, doomed).state, WorkerState::kRendering);
  EXPECT_TRUE(viewOf(c, doomed).attached);

  ASSERT_TRUE(c.workerLost(doomed, "connection broke", stream));
  EXPECT_FALSE(c.workerLost(doomed, "connection broke", stream)) << "a worker is lost once";

  const WorkerView lost = viewOf(c, doomed);
  EXPECT_EQ(lost.state, WorkerState::kLost);
  EXPECT_FALSE(lost.attached);
  EXPECT_LT(lost.secondsInState, 5.0);
  EXPECT_NE(lost.stateReason.find("connection broke"), std::string::npos) << lost.stateReason;
  EXPECT_NE(lost.stateReason.find("unit 0 of " + job + " queued again"), std::string::npos) << lost.stateReason;
  EXPECT_TRUE(lost.currentJobId.empty());
  EXPECT_EQ(c.job(job).workersBusy, 0u);

  // The unit is leased again at once, before any fresh unit, and only once.
  const auto again = c.lease(survivor, 0);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->unit.index, 0u);
  EXPECT_NE(again->leaseId, held->leaseId);
  const auto next = c.lease(survivor, 0);
  ASSERT_TRUE(next);
  EXPECT_EQ(next->unit.index, 1u) << "unit 0 must not be handed out twice";

  // The lost worker's late upload is refused; its id is refused for every call.
  EXPECT_EQ(kindOf([&] { c.acceptResult(resultFor(doomed, *held, 1.0)); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(kindOf([&] { c.heartbeat(doomed, {held->leaseId}); }), FarmError::Kind::kUnknownWorker);
  EXPECT_EQ(kindOf([&] { c.lease(doomed, 0); }), FarmError::Kind::kUnknownWorker);
  EXPECT_EQ(kindOf([&] { c.attachWorker(doomed); }), FarmError::Kind::kUnknownWorker);

  // Every unit counted once: the survivor's results make the whole image.
  EXPECT_TRUE(c.acceptResult(resultFor(survivor, *again, 1.0)));
  EXPECT_TRUE(c.acceptResult(resultFor(survivor, *next, 1.0)));
  while (auto g = c.lease(survivor, 0)) EXPECT_TRUE(c.acceptResult(resultFor(survivor, *g, 1.0)));
  const JobInfo done = c.job(job);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.unitsDone, 4u);
  EXPECT_EQ(done.stats.paths, 4u * 12u);
  const MetricsSnapshot m = c.metricsSnapshot();
  EXPECT_EQ(m.workersLost, 1u);
  EXPECT_EQ(m.unitsLeased, 5u) << "4 units, one of them twice";
  EXPECT_EQ(m.unitsDone, 4u);
  const std::string metrics = renderMetrics(m);
  EXPECT_NE(metrics.find("lensfarm_workers{state=\"lost\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("lensfarm_workers_lost_total 1"), std::string::npos) << metrics;

  // The same worker back under its name replaces the lost entry.
  const std::string back = c.registerWorker(workerInfo("doomed"));
  EXPECT_NE(back, doomed);
  EXPECT_EQ(c.workers().size(), 2u);
}

TEST(Liveness, OnlyTheWorkersCurrentStreamCanLoseIt) {
  Coordinator c(longLeases());
  const std::string w = c.registerWorker(workerInfo("w"));
  const uint64_t first = c.attachWorker(w);
  const uint64_t second = c.attachWorker(w);  // it re-attached: the first stream's end is old news
  EXPECT_NE(first, second);
  EXPECT_FALSE(c.workerLost(w, "connection broke", first));
  EXPECT_EQ(viewOf(c, w).state, WorkerState::kIdle);
  EXPECT_TRUE(c.workerLost(w, "connection broke", second));
  EXPECT_EQ(viewOf(c, w).state, WorkerState::kLost);
  EXPECT_FALSE(c.workerLost("worker-nobody", "connection broke"));
}

TEST(Liveness, AWorkerThatLeavesIsLeftNotLostAndGivesBackWhatItHeld) {
  Coordinator c(longLeases());
  const std::string job = c.submit(specFor(2), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const uint64_t stream = c.attachWorker(w);
  ASSERT_TRUE(c.lease(w, 0));
  c.workerLeft(w, stream);
  const WorkerView v = viewOf(c, w);
  EXPECT_EQ(v.state, WorkerState::kLeft);
  EXPECT_NE(v.stateReason.find("stopped"), std::string::npos) << v.stateReason;
  EXPECT_EQ(c.metricsSnapshot().workersLost, 0u);
  const std::string other = c.registerWorker(workerInfo("other"));
  const auto g = c.lease(other, 0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->unit.index, 0u);
  EXPECT_EQ(c.job(job).state, JobState::kRunning);
}

TEST(Liveness, AStalledJobSaysWhyAndARenderedOneDoesNot) {
  Coordinator c(longLeases());
  const std::string job = c.submit(specFor(8), 0).id;
  const std::string w = c.registerWorker(workerInfo("w1"));
  const uint64_t stream = c.attachWorker(w);
  ASSERT_TRUE(c.lease(w, 0));
  EXPECT_EQ(c.job(job).stalledReason, "") << "a worker renders it";

  ASSERT_TRUE(c.workerLost(w, "connection broke", stream));
  const std::string why = c.job(job).stalledReason;
  EXPECT_NE(why.find("worker w1 (" + w + ") lost 0 s ago (connection broke)"), std::string::npos) << why;
  EXPECT_NE(why.find("unit 0 queued again"), std::string::npos) << why;
  EXPECT_NE(why.find("no workers connected"), std::string::npos) << why;

  // A worker busy with a job of higher priority: the job waits for it.
  const std::string urgent = c.submit(specFor(8), 5).id;
  const std::string busy = c.registerWorker(workerInfo("busy"));
  const auto g = c.lease(busy, 0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->jobId, urgent);
  EXPECT_NE(c.job(job).stalledReason.find("waiting for a worker: the only one is rendering other jobs"),
            std::string::npos)
      << c.job(job).stalledReason;
  EXPECT_EQ(c.job(urgent).stalledReason, "");

  // An idle worker is about to take it: not stalled.
  c.registerWorker(workerInfo("idle"));
  EXPECT_EQ(c.job(job).stalledReason, "");
}

TEST(Liveness, AWorkerThatNeverAttachesIsJudgedByHeartbeatsAsBefore) {
  Coordinator::Options o;
  o.leaseTimeoutSeconds = 0.3;
  o.heartbeatIntervalSeconds = 0.01;
  Coordinator c(o);
  const std::string job = c.submit(specFor(2), 0).id;
  const std::string old = c.registerWorker(workerInfo("old"));
  const auto held = c.lease(old, 0);
  ASSERT_TRUE(held);
  EXPECT_FALSE(viewOf(c, old).attached);
  // Silent past the lease timeout: shown as lost; the lease lapses when another worker calls in.
  ASSERT_TRUE(test::waitFor([&] { return viewOf(c, old).state == WorkerState::kLost; }, 10));
  EXPECT_NE(viewOf(c, old).stateReason.find("not attached"), std::string::npos);
  const std::string other = c.registerWorker(workerInfo("other"));
  const auto g = c.lease(other, 0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->unit.index, 0u);
  // Its id still works (no Attach stream broke): heartbeats learn the lease was revoked.
  EXPECT_EQ(c.heartbeat(old, {held->leaseId}), std::vector<uint64_t>{held->leaseId});
  EXPECT_EQ(c.job(job).state, JobState::kRunning);
}

TEST(Liveness, TheDashboardShowsProgressTowardATargetOrDeadlineWithoutASampleCap) {
  Coordinator c(longLeases());
  Dashboard d(c, std::nullopt);
  // What `lensfarm submit --target-error E` (no --spp) sends: the internal cap only.
  const std::string target = c.submit(specFor(kMaxSamplesPerPixel, 1e-9), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  for (int k = 0; k < 4; ++k) {
    const auto g = c.lease(w, 0);
    ASSERT_TRUE(g);
    ASSERT_TRUE(c.acceptResult(resultFor(w, *g, g->unit.index % 2 ? 1.5 : 1.0)));
  }
  json j = json::parse(d.jobJson(target));
  EXPECT_TRUE(j["spp_total"].is_null()) << "the internal cap is no total: " << j["spp_total"];
  EXPECT_TRUE(j["units_total"].is_null());
  const double estimate = j["estimated_error"].get<double>();
  ASSERT_GT(estimate, 0.0);
  EXPECT_NEAR(j["progress"].get<double>(), (1e-9 / estimate) * (1e-9 / estimate), 1e-30);

  // A deadline: the share of it used since submission.
  c.cancel(target);
  const std::string deadline = c.submit(specFor(kMaxSamplesPerPixel, 0.0, 2.0), 0).id;
  ASSERT_TRUE(test::waitFor([&] { return json::parse(d.jobJson(deadline))["progress"].get<double>() >= 0.25; }, 10))
      << d.jobJson(deadline);
  j = json::parse(d.jobJson(deadline));
  EXPECT_LT(j["progress"].get<double>(), 1.0);
  EXPECT_NEAR(json::parse(d.jobsJson())["jobs"][1]["progress"].get<double>(), j["progress"].get<double>(), 0.1)
      << "the list shows the same";

  // With a cap of its own, the units.
  const std::string capped = c.submit(specFor(8), 9).id;
  const auto g = c.lease(w, 0);
  ASSERT_TRUE(g);
  ASSERT_EQ(g->jobId, capped);
  ASSERT_TRUE(c.acceptResult(resultFor(w, *g, 1.0)));
  j = json::parse(d.jobJson(capped));
  EXPECT_EQ(j["spp_total"], 8);
  EXPECT_DOUBLE_EQ(j["progress"].get<double>(), 1.0 / 8);
}

}  // namespace
}  // namespace lensfarm
