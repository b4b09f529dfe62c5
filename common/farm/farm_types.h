#pragma once
// The farm's vocabulary as plain C++ types: what a coordinator and a worker exchange, with no
// network code. The gRPC services translate these to and from lensfarm.v1 messages
// (proto/convert.h); `lensfarm render` passes them directly between an embedded coordinator
// and worker, so both paths run the same classes.
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <optional>
#include "common/farm/sums_codec.h"
#include "common/film/path_stats.h"
#include "common/film/sensor.h"
#include "common/film/work_unit.h"

#include "common/scene/frame_range.h"
#include "common/scene/render_overrides.h"

namespace lensfarm {

inline constexpr const char* kProtocolVersion = "lensfarm.v1";

// Everything needed to render a job; identical for the coordinator and every worker.
struct JobSpec {
  std::string sceneName;                      // the scene file's name, for people
  std::string sceneJson;                      // the scene file's text
  std::map<std::string, std::string> assets;  // relative path -> SHA-256 of its bytes
  RenderOverrides overrides;
  // Unset: a still. Set: an animation, one image per frame (farm/job_layout.h).
  std::optional<FrameRange> frames;
};

struct WorkerInfo {
  std::string name;
  uint32_t threads = 1;
  std::string protocolVersion = kProtocolVersion;
  std::string rendererVersion;
  // The most memory one unit of a job may take on this worker (farm/memory_estimate.h,
  // workerJobMemory); 0: not said (any unit is leased to it). The coordinator leases a worker only
  // units it can hold, so a small machine in a big farm never fails a big job.
  uint64_t maxUnitMemoryBytes = 0;
  // The per-machine credential it registered with (docs/farm.md "Worker identity"); empty for the
  // shared worker token or none. Set by the coordinator from the call's token, never by the worker.
  std::string credential{};
  // The traversal kernels it runs (util/trace_kernel.h names; empty: not said), its build identity
  // (render/build_identity.h) and CPU model: a result's provenance (docs/farm.md "Mixed machines").
  std::vector<std::string> kernels{};
  std::string build{};
  std::string cpu{};
  // Its tags (--tags; farm/job_policy.h's conventions): jobs that require tags are leased only to
  // workers with all of them (docs/farm.md "Scheduling").
  std::vector<std::string> tags{};
};

// A unit leased to one worker. Only an upload quoting the current lease id is counted.
struct LeaseGrant {
  uint64_t leaseId = 0;
  std::string jobId;
  WorkUnit unit;
  std::string sceneHash;
  double deadlineSeconds = 0.0;
  // How the coordinator wants the sums uploaded (a wire concern: the gRPC service sets it, the
  // gRPC link honours it; an in-process link ignores it).
  SumsEncoding uploadEncoding = SumsEncoding::kRaw;
  // The job's traversal kernel (util/trace_kernel.h): the worker renders the unit with it. Empty:
  // its own widest.
  std::string kernel{};
};

// A unit's partial sensor buffer and the counters of its paths.
struct UnitResult {
  std::string workerId;
  uint64_t leaseId = 0;
  std::string jobId;
  uint64_t unitIndex = 0;
  SensorBuffer buffer;
  PathStats stats;
  double renderSeconds = 0.0;
  SumsEncoding uploadEncoding = SumsEncoding::kRaw;  // the lease's (LeaseGrant::uploadEncoding)
  std::string kernel{};                              // the traversal kernel it was rendered with; empty: not said
};

// An empty result addressed to `grant`'s lease: what `workerId` fills in and uploads.
inline UnitResult resultForLease(const std::string& workerId, const LeaseGrant& grant) {
  UnitResult r;
  r.workerId = workerId;
  r.leaseId = grant.leaseId;
  r.jobId = grant.jobId;
  r.unitIndex = grant.unit.index;
  r.uploadEncoding = grant.uploadEncoding;
  r.kernel = grant.kernel;
  return r;
}

// Failures of farm requests, by kind; the gRPC layer maps each to a status code.
class FarmError : public std::runtime_error {
 public:
  enum class Kind {
    kNotFound,            // unknown job, lease or asset
    kUnknownWorker,       // the coordinator does not know this worker (e.g. it restarted)
    kInvalidArgument,     // a malformed request (a bad scene is an InputError instead)
    kFailedPrecondition,  // e.g. assets missing, versions differ, lease not held
    kUnauthenticated,     // missing or wrong token: retrying will not help
    kPermissionDenied,    // a caller that is not who it names (a worker's session)
    kResourceExhausted,   // the job does not fit in the memory allowed (farm/memory_estimate.h)
  };
  FarmError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

}  // namespace lensfarm
