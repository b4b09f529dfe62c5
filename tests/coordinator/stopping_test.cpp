// Jobs that stop before their sample count: at a target error (the first prefix of units whose
// estimate reaches it, whatever order results arrive in, and the same after a restart) or at a
// deadline (whole units only, at least one). Driven directly, no network.
#include <gtest/gtest.h>

#include <random>

#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

constexpr int kW = 16, kH = 12;

JobSpec noisySpec(uint64_t spp, double targetError, double timeLimit) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {kW, kH};
  JobSpec spec;
  spec.sceneName = "noisy.json";
  spec.sceneJson = scene.dump();
  if (targetError > 0) spec.overrides.targetError = targetError;
  if (timeLimit > 0) spec.overrides.timeLimitSeconds = timeLimit;
  return spec;
}

// Unit k's buffer: one sample per cell of 1 + Gaussian noise (sigma 0.5), a function of k alone.
SensorBuffer noisyUnit(uint64_t k) {
  std::mt19937_64 rng(1000 + k);
  std::normal_distribution<double> noise(0.0, 0.5);
  SensorBuffer b(kW, kH);
  for (double& v : b.sums) v = std::max(0.0, 1.0 + noise(rng));  // radiance is never negative
  std::fill(b.samples.begin(), b.samples.end(), 1u);
  return b;
}

UnitResult resultOf(const std::string& worker, const LeaseGrant& g) {
  UnitResult r = resultForLease(worker, g);
  r.buffer = noisyUnit(g.unit.index);
  r.stats.paths = kW * kH;
  return r;
}

// The first k >= 2 whose prefix [0, k) has an estimate at or below the target: worked out here
// with the tracker alone, independently of the coordinator's scheduling.
uint64_t expectedStop(double target, uint64_t cap) {
  Sensor sensor(kW, kH);
  ConvergenceTracker tracker(kW, kH);
  for (uint64_t k = 0; k < cap; ++k) {
    const SensorBuffer b = noisyUnit(k);
    sensor.add(b);
    tracker.add(k, b);
    const ErrorEstimate e = tracker.estimate(sensor);
    if (e.valid && e.relativeRmse <= target) return k + 1;
  }
  return cap;
}

TEST(Stopping, ATargetErrorJobKeepsTheFirstPrefixThatReachesItWhateverTheArrivalOrder) {
  const double target = 0.12;  // 0.5 / sqrt(n) relative to 1: about 17 units
  const uint64_t stop = expectedStop(target, 64);
  ASSERT_GT(stop, 8u);
  ASSERT_LT(stop, 40u);
  Coordinator c;
  const JobInfo job = c.submit(noisySpec(64, target, 0), 0);
  EXPECT_EQ(job.targetError, target);
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  std::vector<LeaseGrant> grants;
  while (auto g = c.lease(a, 0)) grants.push_back(*g);
  ASSERT_EQ(grants.size(), 64u);
  // Results arrive newest first: units past the stop arrive before it is known and must not count.
  size_t accepted = 0;
  for (auto it = grants.rbegin(); it != grants.rend(); ++it) {
    try {
      c.acceptResult(resultOf(a, *it));
      ++accepted;
    } catch (const FarmError&) {
    }
  }
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.stopReason, "target error reached");
  EXPECT_EQ(done.unitsDone, stop);
  EXPECT_EQ(done.samplesPerPixelDone, stop);
  EXPECT_LE(done.estimatedRelativeError, target);
  EXPECT_EQ(c.image(job.id).metadata.totalSamples, stop * kW * kH) << "no unit past the stop is in the image";
  EXPECT_FALSE(c.lease(a, 0)) << "a stopped job hands out nothing";
}

// A scene whose light the first paths miss: units 0-3 are black. Their estimate is unknown (0/0),
// not 0, so the job goes on until the lit units bring the estimate to the target.
TEST(Stopping, ATargetErrorJobWhoseFirstUnitsAreBlackDoesNotStopOnThem) {
  constexpr uint64_t kBlack = 4;
  const auto unitOf = [](uint64_t k) {
    if (k >= kBlack) return noisyUnit(k);
    SensorBuffer black(kW, kH);
    std::fill(black.samples.begin(), black.samples.end(), 1u);
    return black;
  };
  const double target = 0.12;
  // The expected stop, worked out with the tracker alone.
  uint64_t stop = 64;
  {
    Sensor sensor(kW, kH);
    ConvergenceTracker tracker(kW, kH);
    for (uint64_t k = 0; k < 64; ++k) {
      sensor.add(unitOf(k));
      tracker.add(k, unitOf(k));
      const ErrorEstimate e = tracker.estimate(sensor);
      if (k < kBlack) {
        EXPECT_FALSE(e.valid) << "unit " << k << ": black so far";
      }
      if (e.valid && e.relativeRmse <= target) {
        stop = k + 1;
        break;
      }
    }
  }
  ASSERT_GT(stop, kBlack + 2);
  ASSERT_LT(stop, 64u);

  Coordinator c;
  const JobInfo job = c.submit(noisySpec(64, target, 0), 0);
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  for (uint64_t k = 0; k < kBlack; ++k) {
    const auto g = c.lease(a, 0);
    ASSERT_TRUE(g);
    UnitResult r = resultOf(a, *g);
    r.buffer = unitOf(g->unit.index);
    c.acceptResult(r);
  }
  const JobInfo dark = c.job(job.id);
  EXPECT_EQ(dark.state, JobState::kRunning) << dark.stopReason;
  EXPECT_EQ(dark.unitsDone, kBlack);
  EXPECT_LT(dark.estimatedRelativeError, 0.0) << "unknown, not 0";
  EXPECT_EQ(dark.secondsToTarget, 0.0);

  while (auto g = c.lease(a, 0)) c.acceptResult(resultOf(a, *g));
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.stopReason, "target error reached");
  EXPECT_EQ(done.unitsDone, stop);
  EXPECT_GT(done.estimatedRelativeError, 0.0);
  EXPECT_LE(done.estimatedRelativeError, target);
}

TEST(Stopping, ATargetErrorJobStopsAtItsSampleCapIfTheTargetIsOutOfReach) {
  Coordinator c;
  const JobInfo job = c.submit(noisySpec(6, 0.001, 0), 0);
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  while (auto g = c.lease(a, 0)) c.acceptResult(resultOf(a, *g));
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.unitsDone, 6u);
  EXPECT_EQ(done.stopReason, "sample cap reached before the target error");
  EXPECT_GT(done.estimatedRelativeError, 0.001);
}

TEST(Stopping, TheEstimateIsReportedWithProgressAndProjectsTheTimeToTheTarget) {
  Coordinator c;
  const JobInfo job = c.submit(noisySpec(1000, 0.01, 0), 0);
  EXPECT_LT(job.estimatedRelativeError, 0.0) << "unknown before two units";
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  for (int k = 0; k < 4; ++k) c.acceptResult(resultOf(a, *c.lease(a, 0)));
  const JobInfo running = c.job(job.id);
  EXPECT_EQ(running.state, JobState::kRunning);
  EXPECT_NEAR(running.estimatedRelativeError, 0.5 / 2.0, 0.05) << "sigma / sqrt(4 samples)";
  EXPECT_GT(running.secondsToTarget, 0.0);
}

TEST(Stopping, ADeadlineKeepsTheWholeUnitsDoneByThenAndRevokesTheRest) {
  Coordinator::Options options;
  Coordinator c(options);
  const JobInfo job = c.submit(noisySpec(1000, 0, 0.5), 0);
  EXPECT_EQ(job.timeLimitSeconds, 0.5);
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  const auto g0 = c.lease(a, 0), g1 = c.lease(a, 0), g2 = c.lease(a, 0);
  ASSERT_TRUE(g0 && g1 && g2);
  c.acceptResult(resultOf(a, *g0));
  c.acceptResult(resultOf(a, *g2));  // waits for unit 1, which never comes in time
  // Heartbeats are when the coordinator looks at the clock.
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(a, {g1->leaseId});
        return c.job(job.id).state == JobState::kDone;
      },
      10));
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.stopReason, "deadline reached");
  EXPECT_EQ(done.unitsDone, 1u) << "unit 2 arrived, but without unit 1 the frame would not be whole passes";
  EXPECT_EQ(c.heartbeat(a, {g1->leaseId}), std::vector<uint64_t>{g1->leaseId}) << "the unit in flight is revoked";
  EXPECT_THROW(c.acceptResult(resultOf(a, *g1)), FarmError);
  EXPECT_EQ(c.image(job.id).metadata.totalSamples, uint64_t(kW * kH));
}

TEST(Stopping, ADeadlineBeforeAnyUnitKeepsTheFirstWholeUnit) {
  Coordinator c;
  // Long enough for the two leases below to be granted before the deadline even on a loaded
  // machine (0.05 s was not: a lease after the deadline is refused), short enough to wait for.
  const JobInfo job = c.submit(noisySpec(1000, 0, 1.0), 0);
  const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
  const auto g0 = c.lease(a, 0), g1 = c.lease(a, 0);
  ASSERT_TRUE(g0 && g1) << "both leases are granted before the deadline";
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(a, {g0->leaseId, g1->leaseId});
        return c.job(job.id).remainingSeconds == 0.0;
      },
      10));
  EXPECT_EQ(c.job(job.id).state, JobState::kRunning) << "no image yet: it waits for one pass";
  c.acceptResult(resultOf(a, *g1));
  EXPECT_EQ(c.job(job.id).state, JobState::kRunning) << "unit 1 alone is not a prefix";
  c.acceptResult(resultOf(a, *g0));
  const JobInfo done = c.job(job.id);
  EXPECT_EQ(done.state, JobState::kDone);
  EXPECT_EQ(done.unitsDone, 1u);
  EXPECT_EQ(done.stopReason, "deadline reached");
}

TEST(Stopping, ARestartedCoordinatorKeepsTheSameStop) {
  test::TempDir dir;
  const double target = 0.12;
  const uint64_t stop = expectedStop(target, 64);
  std::string id;
  {
    Coordinator::Options options;
    options.stateDir = dir / "state";
    Coordinator c(options);
    id = c.submit(noisySpec(64, target, 0), 0).id;
    const std::string a = c.registerWorker(WorkerInfo{"a", 1, kProtocolVersion, kRendererVersion});
    // Half the units before a checkpoint, the rest only in the ledger.
    for (uint64_t k = 0; k < stop / 2; ++k) c.acceptResult(resultOf(a, *c.lease(a, 0)));
    c.checkpoint();
    while (c.job(id).state == JobState::kRunning) {
      const auto g = c.lease(a, 0);
      if (!g) break;
      c.acceptResult(resultOf(a, *g));
    }
    EXPECT_EQ(c.job(id).unitsDone, stop);
  }
  Coordinator::Options options;
  options.stateDir = dir / "state";
  Coordinator restarted(options);
  const JobInfo job = restarted.job(id);
  EXPECT_EQ(job.state, JobState::kDone);
  EXPECT_EQ(job.unitsDone, stop);
  EXPECT_EQ(job.stopReason, "target error reached");
  EXPECT_EQ(restarted.image(id).metadata.totalSamples, stop * kW * kH);
}

}  // namespace
}  // namespace lensfarm
