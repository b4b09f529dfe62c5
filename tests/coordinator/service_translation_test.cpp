// The coordinator's translation of what it reports into the wire's messages (service.h):
// JobInfo as JobStatus and WorkerView as WorkerStatus, with hand-filled values, so that every
// field of the cross-worker audit (docs/farm.md "Audit") is seen to arrive.
#include <gtest/gtest.h>

#include "coordinator/rpc/service.h"
#include "tests/coordinator/audit_views.h"

namespace lensfarm {
namespace {

TEST(ServiceTranslation, JobStatusCarriesTheAuditCountsAndTheEvents) {
  const JobInfo info = test::auditedJob();
  const v1::JobStatus s = toProto(info);
  EXPECT_EQ(s.job_id(), "job-7");
  EXPECT_EQ(s.state(), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(s.version(), 42u);
  EXPECT_EQ(s.progress().units_done(), 96u);
  EXPECT_EQ(s.audits_passed(), 12u);
  EXPECT_EQ(s.audits_failed(), 1u);
  EXPECT_EQ(s.audits_pending(), 2u);
  EXPECT_EQ(s.units_rerendered(), 40u);
  ASSERT_EQ(s.events_size(), 2) << "oldest first, every one";
  for (int k = 0; k < 2; ++k) {
    EXPECT_DOUBLE_EQ(s.events(k).unix_seconds(), info.events[size_t(k)].unixSeconds) << k;
    EXPECT_EQ(s.events(k).text(), info.events[size_t(k)].text) << k;
  }

  const v1::JobStatus none = toProto(JobInfo{});
  EXPECT_EQ(none.audits_passed() + none.audits_failed() + none.audits_pending() + none.units_rerendered(), 0u);
  EXPECT_EQ(none.events_size(), 0);
}

TEST(ServiceTranslation, WorkerStatusCarriesEveryFieldWithQuarantineAndAudits) {
  const std::vector<WorkerView> views = test::auditedWorkers();
  const v1::WorkerStatus a = toProto(views[0]), b = toProto(views[1]);
  // What ListWorkers always carried (the translation moved into toProto).
  EXPECT_EQ(a.worker_id(), "w1");
  EXPECT_EQ(a.name(), "box-1");
  EXPECT_EQ(a.threads(), 6u);
  EXPECT_EQ(a.current_job_id(), "job-7");
  EXPECT_EQ(a.units_done(), 50u);
  EXPECT_DOUBLE_EQ(a.seconds_since_heartbeat(), 0.25);
  EXPECT_EQ(a.renderer_version(), views[0].info.rendererVersion);
  EXPECT_EQ(a.state(), "rendering");
  EXPECT_TRUE(a.attached());
  EXPECT_EQ(a.failures(), 2u);
  ASSERT_EQ(a.blocklisted_jobs_size(), 1);
  EXPECT_EQ(a.blocklisted_jobs(0), "job-2");
  EXPECT_EQ(b.state(), "idle");
  EXPECT_DOUBLE_EQ(b.seconds_in_state(), 7.0);
  // The audit's.
  EXPECT_EQ(a.audits_passed(), 5u);
  EXPECT_FALSE(a.quarantined());
  EXPECT_EQ(a.quarantine_reason(), "");
  EXPECT_EQ(b.audits_passed(), 3u);
  EXPECT_TRUE(b.quarantined());
  EXPECT_EQ(b.quarantine_reason(), test::kQuarantineReason);
}

}  // namespace
}  // namespace lensfarm
