// The dashboard's answers (dashboard.h) and the coordinator's additions behind them (priority
// changes, the error history, workers' current unit and speed), driven directly: no network.
#include <gtest/gtest.h>

#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/web/dashboard.h"
#include "coordinator/web/dashboard_server.h"
#include "tests/coordinator/audit_views.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

JobSpec specFor(uint64_t spp, double targetError = 0.0) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {8, 6};
  if (targetError > 0) scene["render"]["target_error"] = targetError;
  JobSpec spec;
  spec.sceneName = "test.json";
  spec.sceneJson = scene.dump();
  return spec;
}

// A rendered-looking result on the dashboard tests' 8 x 6 frame, rendered in half a second.
UnitResult resultFor(const std::string& worker, const LeaseGrant& g, double value) {
  return test::resultFor(worker, g, value, 0.5, 8, 6);
}
using test::workerInfo;

// Leases and returns `units` units of whatever is first in line, with values that differ between
// the halves so that the error estimate is positive.
void renderUnits(Coordinator& c, const std::string& worker, int units) {
  for (int k = 0; k < units; ++k) {
    const auto g = c.lease(worker, 0);
    ASSERT_TRUE(g);
    ASSERT_TRUE(c.acceptResult(resultFor(worker, *g, g->unit.index % 2 ? 1.5 : 1.0)));
  }
}

TEST(Dashboard, JsonHasWhatThePagesShow) {
  Coordinator c;
  Dashboard d(c, std::nullopt);
  const std::string id = c.submit(specFor(64, 1e-6), 2).id;
  const std::string w = c.registerWorker(workerInfo("box-1", 6));
  renderUnits(c, w, 4);
  const auto held = c.lease(w, 0);
  ASSERT_TRUE(held);

  const json jobs = json::parse(d.jobsJson());
  ASSERT_EQ(jobs["jobs"].size(), 1u);
  const json& j = jobs["jobs"][0];
  EXPECT_EQ(j["id"], id);
  EXPECT_EQ(j["state"], "running");
  EXPECT_EQ(j["priority"], 2);
  EXPECT_EQ(j["scene"], "test.json");
  EXPECT_EQ(j["width"], 8);
  EXPECT_EQ(j["spp_done"], 4);
  EXPECT_EQ(j["spp_total"], 64);
  EXPECT_DOUBLE_EQ(j["progress"].get<double>(), 4.0 / 64);
  EXPECT_GT(j["estimated_error"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(j["target_error"].get<double>(), 1e-6);
  for (const char* key : {"samples_per_second", "elapsed_seconds", "remaining_seconds", "version", "workers_busy"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* key : {"audits_passed", "audits_failed", "audits_pending", "units_rerendered"})
    EXPECT_TRUE(j[key].is_number_unsigned()) << key;

  const json detail = json::parse(d.jobJson(id));
  EXPECT_EQ(detail["id"], id);
  ASSERT_TRUE(detail["effects"].is_array());
  EXPECT_FALSE(detail["effects"].empty());
  EXPECT_TRUE(detail["events"].is_array());
  const json& history = detail["error_history"];
  ASSERT_EQ(history.size(), 3u) << "one point per changed estimate, from the second unit on: " << history;
  EXPECT_EQ(history[0]["spp"], 2);
  EXPECT_EQ(history[2]["spp"], 4);
  EXPECT_DOUBLE_EQ(history[2]["error"].get<double>(), j["estimated_error"].get<double>());
  EXPECT_LE(history[0]["t"].get<double>(), history[2]["t"].get<double>());

  const json workers = json::parse(d.workersJson());
  ASSERT_EQ(workers["workers"].size(), 1u);
  const json& wj = workers["workers"][0];
  EXPECT_EQ(wj["id"], w);
  EXPECT_EQ(wj["name"], "box-1");
  EXPECT_EQ(wj["cores"], 6);
  EXPECT_EQ(wj["current_job"], id);
  EXPECT_EQ(wj["current_unit"], held->unit.index);
  EXPECT_EQ(wj["units_done"], 4);
  EXPECT_DOUBLE_EQ(wj["samples_per_second"].get<double>(), 48.0 / 0.5) << "its last unit's paths / render seconds";
  EXPECT_GE(wj["seconds_since_heartbeat"].get<double>(), 0.0);
  EXPECT_EQ(wj["quarantined"], false);
  EXPECT_EQ(wj["quarantine_reason"], "");
  EXPECT_TRUE(wj["audits_passed"].is_number_unsigned());

  EXPECT_THROW(d.jobJson("job-404"), FarmError);
}

// The cross-worker audit (docs/farm.md "Audit") from a hand-filled job and workers: its counts in
// the job's summary, its events in the detail, and a quarantined worker with the reason.
TEST(Dashboard, JsonCarriesTheAuditItsEventsAndQuarantinedWorkers) {
  const JobInfo info = test::auditedJob();
  const json detail = json::parse(jobDetailJson(info, {}));
  EXPECT_EQ(detail["id"], "job-7");
  EXPECT_EQ(detail["audits_passed"], 12);
  EXPECT_EQ(detail["audits_failed"], 1);
  EXPECT_EQ(detail["audits_pending"], 2);
  EXPECT_EQ(detail["units_rerendered"], 40);
  ASSERT_EQ(detail["events"].size(), 2u) << detail["events"];
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_DOUBLE_EQ(detail["events"][k]["unix_seconds"].get<double>(), info.events[k].unixSeconds) << k;
    EXPECT_EQ(detail["events"][k]["text"], info.events[k].text) << k;
  }
  EXPECT_TRUE(detail["error_history"].empty());

  const json workers = json::parse(workerListJson(test::auditedWorkers()))["workers"];
  ASSERT_EQ(workers.size(), 2u);
  EXPECT_EQ(workers[0]["id"], "w1");
  EXPECT_EQ(workers[0]["audits_passed"], 5);
  EXPECT_EQ(workers[0]["quarantined"], false);
  EXPECT_EQ(workers[0]["failures"], 2);
  EXPECT_EQ(workers[0]["blocklisted_jobs"], json::array({"job-2"}));
  EXPECT_EQ(workers[1]["id"], "w3");
  EXPECT_EQ(workers[1]["state"], "idle");
  EXPECT_EQ(workers[1]["audits_passed"], 3);
  EXPECT_EQ(workers[1]["quarantined"], true);
  EXPECT_EQ(workers[1]["quarantine_reason"], test::kQuarantineReason);
}

TEST(Dashboard, EstimateIsNullUntilKnown) {
  Coordinator c;
  Dashboard d(c, std::nullopt);
  c.submit(specFor(4), 0);
  EXPECT_TRUE(json::parse(d.jobsJson())["jobs"][0]["estimated_error"].is_null());
  EXPECT_TRUE(json::parse(d.workersJson())["workers"].empty());
}

TEST(Dashboard, PauseResumeAndApproveAnswerTheJobsSchedulingState) {
  Coordinator c;
  Dashboard d(c, std::nullopt);
  const std::string first = c.submit(specFor(4), 0).id;
  JobPolicy policy;
  policy.after = {parseDependency(first + ":approved", "after")};
  policy.requireTags = {"bigmem"};
  const std::string second = c.submit(specFor(4), 0, "ann", policy).id;
  const json waiting = json::parse(d.jobsJson())["jobs"][1];
  EXPECT_EQ(waiting["waiting_for"], json::array({first + " to be approved (lensfarm approve " + first + ")"}));
  EXPECT_EQ(waiting["policy"]["after"], json::array({first + ":approved"}));
  EXPECT_EQ(waiting["policy"]["require_tags"], json::array({"bigmem"}));
  EXPECT_TRUE(waiting["policy"]["max_workers"].is_null());
  EXPECT_EQ(json::parse(d.pause(first))["paused"], true);
  EXPECT_EQ(json::parse(d.resume(first))["paused"], false);
  EXPECT_EQ(json::parse(d.approve(first))["approved"], true);
  EXPECT_EQ(json::parse(d.jobsJson())["jobs"][1]["waiting_for"], json::array());
  EXPECT_THROW(d.pause("job-404"), FarmError);
}

TEST(Dashboard, PriorityChangesReorderJobsAndLeases) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  std::string first, second;
  {
    Coordinator c(options);
    Dashboard d(c, std::nullopt);
    first = c.submit(specFor(8), 0).id;
    second = c.submit(specFor(8), 0).id;
    EXPECT_EQ(json::parse(d.jobsJson())["jobs"][0]["id"], first);
    const uint64_t version = c.job(second).version;
    EXPECT_EQ(json::parse(d.setPriority(second, 3))["priority"], 3);
    EXPECT_GT(c.job(second).version, version) << "watchers see the change";
    const json jobs = json::parse(d.jobsJson())["jobs"];
    EXPECT_EQ(jobs[0]["id"], second);
    EXPECT_EQ(jobs[1]["id"], first);
    const std::string w = c.registerWorker(workerInfo("w", 1));
    EXPECT_EQ(c.lease(w, 0)->jobId, second) << "the next unit comes from the raised job";
    EXPECT_THROW(d.setPriority("job-404", 1), FarmError);
  }
  Coordinator restarted(options);
  const auto jobs = restarted.jobs();
  ASSERT_EQ(jobs.size(), 2u);
  EXPECT_EQ(jobs[0].id, second) << "the priority is persisted";
  EXPECT_EQ(jobs[0].priority, 3);
}

TEST(Dashboard, CancelStopsTheJob) {
  Coordinator c;
  Dashboard d(c, std::nullopt);
  const std::string id = c.submit(specFor(8), 0).id;
  EXPECT_EQ(json::parse(d.cancel(id))["state"], "cancelled");
  EXPECT_EQ(c.job(id).state, JobState::kCancelled);
}

TEST(Dashboard, SnapshotsArePngsAtTheAskedExposureAndSize) {
  Coordinator c;
  Dashboard d(c, std::nullopt);
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = 2;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {64, 48};
  JobSpec spec;
  spec.sceneName = "test.json";
  spec.sceneJson = scene.dump();
  const std::string id = c.submit(spec, 0).id;
  const std::string w = c.registerWorker(workerInfo("w", 1));
  const auto g = c.lease(w, 0);
  UnitResult r;
  r.workerId = w;
  r.leaseId = g->leaseId;
  r.jobId = id;
  r.unitIndex = 0;
  r.buffer = SensorBuffer(64, 48);
  for (size_t k = 0; k < r.buffer.sums.size(); ++k) r.buffer.sums[k] = double(k % 97) / 50.0;  // a gradient
  r.stats.paths = 64 * 48 * uint64_t(g->unit.sampleCount);
  ASSERT_TRUE(c.acceptResult(std::move(r)));

  const Dashboard::Png automatic = d.snapshot(id, std::nullopt, 32);
  EXPECT_EQ(automatic.bytes.substr(0, 8), "\x89PNG\r\n\x1a\n");
  EXPECT_EQ(automatic.width, 32);
  EXPECT_EQ(automatic.height, 24);
  EXPECT_EQ(automatic.samplesPerPixel, 1u);
  EXPECT_EQ(automatic.version, c.job(id).version);
  const Dashboard::Png brighter = d.snapshot(id, 2.0, 32), darker = d.snapshot(id, -2.0, 32);
  EXPECT_DOUBLE_EQ(brighter.ev, 2.0);
  EXPECT_NE(brighter.bytes, darker.bytes);
  EXPECT_NE(brighter.bytes, automatic.bytes);
  EXPECT_EQ(d.snapshot(id, std::nullopt, 100000).width, 64) << "never larger than the image";

  const Dashboard::Png full = d.png(id, std::nullopt);
  EXPECT_EQ(full.width, 64);
  EXPECT_EQ(d.exr(id).substr(0, 4), "\x76\x2f\x31\x01") << "OpenEXR magic";
}

TEST(Dashboard, TokenIsCheckedWhenThereIsOne) {
  Coordinator c;
  const Dashboard open(c, std::nullopt), gated(c, std::string("s3cret"));
  EXPECT_TRUE(open.authorized(""));
  EXPECT_FALSE(gated.authorized(""));
  EXPECT_FALSE(gated.authorized("Bearer wrong"));
  EXPECT_FALSE(gated.authorized("s3cret"));
  EXPECT_FALSE(gated.authorized("Bearer s3cre"));
  EXPECT_TRUE(gated.authorized("Bearer s3cret"));
}

TEST(Dashboard, TheViewerTokenReadsAndTheClientTokenDoesEverything) {
  Coordinator c;
  using Access = Dashboard::Access;
  const Dashboard open(c, std::nullopt), client(c, std::string("client-s3cret")),
      both(c, std::string("client-s3cret"), std::string("viewer-s3cret"));
  EXPECT_EQ(open.access(""), Access::kFull) << "no token required: as today";
  EXPECT_EQ(client.access("Bearer viewer-s3cret"), Access::kNone) << "no viewer token configured";
  EXPECT_FALSE(client.viewerToken());
  EXPECT_TRUE(both.viewerToken());
  EXPECT_EQ(both.access("Bearer client-s3cret"), Access::kFull);
  EXPECT_EQ(both.access("Bearer viewer-s3cret"), Access::kRead);
  for (const char* refused : {"", "viewer-s3cret", "Bearer viewer-s3cre", "Bearer viewer-s3cretX", "Bearer ",
                              "Basic dmlld2VyLXMzY3JldA==", "bearer viewer-s3cret"})
    EXPECT_EQ(both.access(refused), Access::kNone) << refused;
}

TEST(Dashboard, ErrorHistoryStaysBoundedAndKeepsItsSpan) {
  Coordinator c;
  const std::string id = c.submit(specFor(1200, 1e-9), 0).id;
  const std::string w = c.registerWorker(workerInfo("w", 1));
  renderUnits(c, w, 1100);
  const auto history = c.errorHistory(id);
  EXPECT_LE(history.size(), Coordinator::kMaxErrorPoints);
  EXPECT_GE(history.size(), Coordinator::kMaxErrorPoints / 2);
  EXPECT_EQ(history.front().samplesPerPixel, 2u) << "the first point survives thinning";
  EXPECT_EQ(history.back().samplesPerPixel, 1100u);
  for (size_t k = 1; k < history.size(); ++k) EXPECT_LT(history[k - 1].samplesPerPixel, history[k].samplesPerPixel);
}

// The DNS-rebinding guard of a tokenless dashboard: the Host must be a loopback name or address,
// exactly, with at most a numeric port; a name that merely begins like one is another site.
TEST(Dashboard, OnlyLoopbackHostsPassTheRebindingGuard) {
  for (const char* host : {"localhost", "localhost:8080", "LocalHost:1", "127.0.0.1", "127.0.0.1:80", "127.1.2.3:65535",
                           "[::1]", "[::1]:8080"})
    EXPECT_TRUE(loopbackHost(host)) << host;
  for (const char* host : {"",
                           "127.attacker.example",
                           "127.0.0.1.nip.io",
                           "127.0.0.1.nip.io:80",
                           "[::1]evil",
                           "[::1]:80evil",
                           "[::1",
                           "localhost.evil.example",
                           "localhost.",
                           "evil.localhost",
                           "127.0.0.1:",
                           "127.0.0.1:80:80",
                           "127.0.0.1:99999",
                           "127.0.0.1:+80",
                           "128.0.0.1",
                           "0.0.0.0",
                           "10.0.0.1:80",
                           "127.0.0.1 ",
                           " 127.0.0.1",
                           "127.0.0.01x",
                           "[::2]",
                           "[::ffff:8.8.8.8]",
                           "127.0.0.1\r\nX: y"})
    EXPECT_FALSE(loopbackHost(host)) << host;
}

}  // namespace
}  // namespace lensfarm
