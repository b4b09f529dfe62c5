#pragma once
// A notification of the farm: what a pipeline reacts to (a job started, reached its target,
// ended; an audit failed; a worker was lost). The coordinator publishes them in order
// (coordinator/core/event_feed.h); ListEvents, the HTTP API's event stream and webhooks carry them
// (docs/api.md "Events").
#include <cstdint>
#include <string>
#include <vector>

namespace lensfarm {

// The event types, as written in FarmEvent::type (docs/api.md lists what each means).
namespace farm_event {
inline constexpr const char* kJobSubmitted = "job.submitted";
inline constexpr const char* kJobStarted = "job.started";
inline constexpr const char* kJobTargetReached = "job.target_reached";
inline constexpr const char* kJobDone = "job.done";
inline constexpr const char* kJobFailed = "job.failed";
inline constexpr const char* kJobCancelled = "job.cancelled";
inline constexpr const char* kJobPaused = "job.paused";
inline constexpr const char* kJobResumed = "job.resumed";
inline constexpr const char* kJobApproved = "job.approved";
inline constexpr const char* kJobDeleted = "job.deleted";
inline constexpr const char* kAuditFailed = "audit.failed";
inline constexpr const char* kWorkerJoined = "worker.joined";
inline constexpr const char* kWorkerLost = "worker.lost";
inline constexpr const char* kWorkerQuarantined = "worker.quarantined";
// Every type, for validating a filter (--webhook-events).
inline const std::vector<std::string>& allTypes() {
  static const std::vector<std::string> types{
      kJobSubmitted, kJobStarted,  kJobTargetReached, kJobDone,     kJobFailed,    kJobCancelled, kJobPaused,
      kJobResumed,   kJobApproved, kJobDeleted,       kAuditFailed, kWorkerJoined, kWorkerLost,   kWorkerQuarantined};
  return types;
}
}  // namespace farm_event

struct FarmEvent {
  uint64_t sequence = 0;
  double unixSeconds = 0.0;
  std::string type;  // one of farm_event
  std::string jobId, workerId, owner;
  std::string text;  // for a person: what happened and why
};

}  // namespace lensfarm
