#pragma once
// How a worker talks to its coordinator: over gRPC (grpc_link.h) in `lensfarm-worker`, or by
// direct calls to an embedded coordinator in `lensfarm render`. The worker loop sees only this.
//
// Failures: LinkUnavailable for transient ones (coordinator down, network dropped; retry with
// backoff); FarmError for answers (kUnknownWorker: register again; kFailedPrecondition: a lease
// no longer held, drop it, or at registration: versions differ, give up).
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/farm/farm_types.h"

namespace lensfarm {

class LinkUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Registration {
  std::string workerId;
  double heartbeatIntervalSeconds = 1.0;
};

class CoordinatorLink {
 public:
  virtual ~CoordinatorLink() = default;
  virtual Registration registerWorker(const WorkerInfo& info) = 0;
  // Returns the leases the worker must drop.
  virtual std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds) = 0;
  virtual std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds) = 0;
  // After a lease() that granted nothing: a job whose assets to fetch into the cache now
  // (prefetch, docs/farm.md "Assets"), or "". Links without prefetch answer "".
  virtual std::string takePrefetch() { return ""; }
  virtual JobSpec jobSpec(const std::string& jobId) = 0;
  virtual std::string asset(const std::string& sha256) = 0;
  // True if counted, false if the coordinator already had the unit (a harmless duplicate).
  virtual bool upload(const UnitResult& result) = 0;
  virtual void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                             const std::string& error) = 0;
  // The worker is stopping cleanly (after its last unit): the coordinator shows it as left, not
  // lost. Links without a liveness stream (direct calls) need not do anything.
  virtual void leave() {}
};

}  // namespace lensfarm
