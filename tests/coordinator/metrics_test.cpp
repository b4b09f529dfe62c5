// The coordinator's Prometheus metrics rendered from a Coordinator driven directly (no network):
// well-formed text, and values that follow what the coordinator does.
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/metrics.h"
#include "tests/coordinator/audit_views.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

// A 4 x 3 job of `units` units of one sample each.
JobSpec smallJob(uint64_t units) {
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"].update({{"resolution", {4, 3}}, {"samples_per_pixel", units}, {"samples_per_unit", 1}});
  return JobSpec{"metrics.json", scene.dump(), {}, {}, std::nullopt};
}

// The result of a granted unit: sums of 0.5, one path per pixel.
UnitResult rendered(const std::string& workerId, const LeaseGrant& grant) {
  UnitResult r{workerId, grant.leaseId, grant.jobId, grant.unit.index, SensorBuffer(4, 3), {}, 0.0};
  std::fill(r.buffer.sums.begin(), r.buffer.sums.end(), 0.5);
  r.stats.paths = 12;
  return r;
}

std::map<std::string, double> scrape(const Coordinator& c) {
  return test::parseMetrics(renderMetrics(c.metricsSnapshot()));
}

TEST(Metrics, FollowWhatTheCoordinatorDoes) {
  Coordinator::Options options;
  options.leaseTimeoutSeconds = 0.2;
  options.auditFraction = 0.0;  // exact counts of leases (the audit's: audit_test.cpp)
  Coordinator c(options);
  auto m = scrape(c);
  EXPECT_EQ(m.at("lensfarm_build_info{version=\"" + std::string(kRendererVersion) + "\"}"), 1.0);
  for (const char* state : {"queued", "running", "done", "cancelled", "failed"})
    EXPECT_EQ(m.at(std::string("lensfarm_jobs{state=\"") + state + "\"}"), 0.0) << state;
  EXPECT_EQ(m.at("lensfarm_workers_known"), 0.0);
  EXPECT_EQ(m.at("lensfarm_audits_total{result=\"passed\"}"), 0.0);
  EXPECT_EQ(m.at("lensfarm_audits_total{result=\"failed\"}"), 0.0);
  EXPECT_EQ(m.at("lensfarm_units_rerendered_total"), 0.0);
  EXPECT_EQ(m.at("lensfarm_workers_quarantined"), 0.0);

  const std::string sha = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";  // "hello\n"
  c.putAsset(sha, "hello\n");
  const std::string job = c.submit(smallJob(3), 0).id;
  c.cancel(c.submit(smallJob(1), 0).id);
  const std::string steady = c.registerWorker(WorkerInfo{"steady", 1, kProtocolVersion, kRendererVersion});
  const std::string doomed = c.registerWorker(WorkerInfo{"doomed", 1, kProtocolVersion, kRendererVersion});
  m = scrape(c);
  EXPECT_EQ(m.at("lensfarm_jobs{state=\"queued\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_jobs{state=\"cancelled\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_received_bytes_total{kind=\"asset\"}"), 6.0);
  EXPECT_EQ(m.at("lensfarm_workers_alive"), 2.0);
  EXPECT_EQ(m.at("lensfarm_workers_known"), 2.0);

  const auto first = c.lease(steady, 0.0);
  const auto lost = c.lease(doomed, 0.0);
  ASSERT_TRUE(first && lost);
  m = scrape(c);
  EXPECT_EQ(m.at("lensfarm_jobs{state=\"running\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_units_leased_total"), 2.0);
  EXPECT_EQ(m.at("lensfarm_leases_active"), 2.0);
  EXPECT_EQ(m.at("lensfarm_units_done_total"), 0.0);

  ASSERT_TRUE(c.acceptResult(rendered(steady, *first)));
  m = scrape(c);
  EXPECT_EQ(m.at("lensfarm_units_done_total"), 1.0);
  EXPECT_EQ(m.at("lensfarm_samples_total"), 12.0);
  EXPECT_EQ(m.at("lensfarm_received_bytes_total{kind=\"unit\"}"), 4.0 * 3 * 3 * sizeof(double));
  EXPECT_GT(m.at("lensfarm_samples_per_second"), 0.0) << "a running job with samples in";
  EXPECT_EQ(m.at("lensfarm_leases_active"), 1.0);

  // `doomed` goes silent: its lease lapses, and it is no longer alive; `steady` keeps calling in.
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(steady, {});
        return scrape(c).at("lensfarm_units_expired_total") == 1.0;
      },
      10));
  ASSERT_TRUE(test::waitFor(
      [&] {
        c.heartbeat(steady, {});
        return scrape(c).at("lensfarm_workers_alive") == 1.0;
      },
      10));
  m = scrape(c);
  EXPECT_EQ(m.at("lensfarm_workers_known"), 2.0) << "silent, not yet forgotten";
  EXPECT_EQ(m.at("lensfarm_leases_active"), 0.0);

  // The lapsed unit and the last one are leased again and finish the job.
  while (auto grant = c.lease(steady, 0.0)) ASSERT_TRUE(c.acceptResult(rendered(steady, *grant)));
  m = scrape(c);
  EXPECT_EQ(c.job(job).state, JobState::kDone);
  EXPECT_EQ(m.at("lensfarm_jobs{state=\"done\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_jobs{state=\"running\"}"), 0.0);
  EXPECT_EQ(m.at("lensfarm_units_leased_total"), 4.0) << "3 units, one of them twice";
  EXPECT_EQ(m.at("lensfarm_units_done_total"), 3.0);
  EXPECT_EQ(m.at("lensfarm_samples_total"), 36.0);
  EXPECT_EQ(m.at("lensfarm_received_bytes_total{kind=\"unit\"}"), 3 * 4.0 * 3 * 3 * sizeof(double));
  EXPECT_EQ(m.at("lensfarm_samples_per_second"), 0.0) << "no job running";
}

// The cross-worker audit's (docs/farm.md "Audit") from a hand-filled snapshot: its two counters
// as they are, and the quarantined workers counted among the known ones.
TEST(Metrics, CountAuditsUnitsRenderedAgainAndQuarantinedWorkers) {
  MetricsSnapshot s;
  s.auditsPassed = 12;
  s.auditsFailed = 1;
  s.unitsRerendered = 40;
  s.workers = test::auditedWorkers();  // w1 rendering, w3 idle and quarantined
  s.workers.push_back(s.workers[1]);
  s.workers.back().id = "w4";
  s.workers.back().state = WorkerState::kLost;  // quarantined, then lost: still known, still counted
  const auto m = test::parseMetrics(renderMetrics(s));
  EXPECT_EQ(m.at("lensfarm_audits_total{result=\"passed\"}"), 12.0);
  EXPECT_EQ(m.at("lensfarm_audits_total{result=\"failed\"}"), 1.0);
  EXPECT_EQ(m.at("lensfarm_units_rerendered_total"), 40.0);
  EXPECT_EQ(m.at("lensfarm_workers_quarantined"), 2.0);
  EXPECT_EQ(m.at("lensfarm_workers_known"), 3.0);
}

TEST(Metrics, EveryFamilyHasHelpAndTypeAndCountersEndInTotal) {
  const std::string text = renderMetrics(Coordinator().metricsSnapshot());
  // parseMetrics fails the test on any line that breaks the format or the naming rules.
  const auto samples = test::parseMetrics(text);
  EXPECT_GE(samples.size(), 16u);
  for (const char* family : {"lensfarm_jobs", "lensfarm_units_leased_total", "lensfarm_units_done_total",
                             "lensfarm_units_expired_total", "lensfarm_samples_total", "lensfarm_samples_per_second",
                             "lensfarm_received_bytes_total", "lensfarm_workers_alive", "lensfarm_audits_total",
                             "lensfarm_units_rerendered_total", "lensfarm_workers_quarantined"})
    EXPECT_NE(text.find(std::string("# TYPE ") + family + " "), std::string::npos) << family;
  // A broken line is caught: the parser is not a rubber stamp.
  EXPECT_NONFATAL_FAILURE(test::parseMetrics("lensfarm_orphan 1\n"), "without HELP and TYPE");
  EXPECT_NONFATAL_FAILURE(test::parseMetrics("# HELP lensfarm_x x\n# TYPE lensfarm_x counter\nlensfarm_x 1\n"),
                          "_total");
}

}  // namespace
}  // namespace lensfarm
