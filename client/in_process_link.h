#pragma once
// CoordinatorLink by direct calls to a Coordinator in the same process: `lensfarm render` runs an
// embedded coordinator and worker through the same classes the farm uses over gRPC.
#include "coordinator/core/coordinator.h"
#include "worker/coordinator_link.h"

namespace lensfarm {

class InProcessLink final : public CoordinatorLink {
 public:
  explicit InProcessLink(Coordinator& coordinator) : coordinator_(coordinator) {}

  Registration registerWorker(const WorkerInfo& info) override {
    return Registration{coordinator_.registerWorker(info), coordinator_.options().heartbeatIntervalSeconds};
  }
  std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds) override {
    return coordinator_.heartbeat(workerId, leaseIds);
  }
  std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds) override {
    return coordinator_.lease(workerId, waitSeconds);
  }
  JobSpec jobSpec(const std::string& jobId) override { return coordinator_.jobSpec(jobId); }
  std::string asset(const std::string& sha256) override { return *coordinator_.asset(sha256); }
  bool upload(const UnitResult& result) override { return coordinator_.acceptResult(result); }
  void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                     const std::string& error) override {
    coordinator_.reportFailure(workerId, leaseId, jobId, error);
  }

 private:
  Coordinator& coordinator_;
};

}  // namespace lensfarm
