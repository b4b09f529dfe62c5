#pragma once
// A hand-filled job and workers with every field of the cross-worker audit set (docs/farm.md
// "Audit"), for the tests of what shows them: the gRPC translation (service.h), the CLI, the
// dashboard's JSON and page, and the metrics. The values differ from each other, so a field
// copied into the wrong one shows.
#include <vector>

#include "common/util/version.h"
#include "coordinator/core/coordinator.h"

namespace lensfarm::test {

// Event times: 2026-11-18 11:06:43 and 11:06:44 UTC.
inline constexpr double kAuditEventSeconds[] = {1795000003.0, 1795000004.5};

// job-7: running, 96 of 128 units; 12 audits passed, 1 failed, 2 pending, 40 units rendered
// again, and two events.
inline JobInfo auditedJob() {
  JobInfo j;
  j.id = "job-7";
  j.state = JobState::kRunning;
  j.priority = 1;
  j.sceneName = "audited.json";
  j.sceneHash = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";
  j.width = 64;
  j.height = 48;
  j.samplesPerPixelDone = 96;
  j.samplesPerPixelTotal = 128;
  j.unitsDone = 96;
  j.unitsTotal = 128;
  j.elapsedSeconds = 12.5;
  j.remainingSeconds = 4.0;
  j.workersBusy = 2;
  j.submittedUnixSeconds = 1795000000.0;
  j.version = 42;
  j.estimatedRelativeError = 0.05;
  j.progressFraction = 0.75;
  j.effects = {"depth of field: off (aperture closed (N = infinity))"};
  j.auditsPassed = 12;
  j.auditsFailed = 1;
  j.auditsPending = 2;
  j.unitsRerendered = 40;
  j.events = {{kAuditEventSeconds[0], "audit of unit 12 failed: w2 and w4 agree, w3 differs"},
              {kAuditEventSeconds[1], "worker w3 quarantined; its 40 counted units queued again"}};
  return j;
}

inline const char* const kQuarantineReason =
    "unit 12 of job-7: sums differ from w2 and w4 by up to 1.0e-03 (cell 4711)";

// w1 (box-1): rendering job-7, 5 audits passed, 2 failures, blocklisted for job-2.
// w3 (box-3): idle and quarantined, 3 audits passed before.
inline std::vector<WorkerView> auditedWorkers() {
  WorkerView a;
  a.id = "w1";
  a.info = WorkerInfo{"box-1", 6, kProtocolVersion, kRendererVersion};
  a.currentJobId = "job-7";
  a.currentUnit = 97;
  a.unitsDone = 50;
  a.secondsSinceHeartbeat = 0.25;
  a.samplesPerSecond = 1000.0;
  a.state = WorkerState::kRendering;
  a.attached = true;
  a.failures = 2;
  a.blocklistedJobs = {"job-2"};
  a.auditsPassed = 5;
  WorkerView b;
  b.id = "w3";
  b.info = WorkerInfo{"box-3", 2, kProtocolVersion, kRendererVersion};
  b.unitsDone = 46;
  b.secondsSinceHeartbeat = 0.5;
  b.state = WorkerState::kIdle;
  b.secondsInState = 7.0;
  b.attached = true;
  b.auditsPassed = 3;
  b.quarantined = true;
  b.quarantineReason = kQuarantineReason;
  return {a, b};
}

}  // namespace lensfarm::test
