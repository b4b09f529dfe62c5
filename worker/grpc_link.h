#pragma once
// CoordinatorLink over gRPC (lensfarm.v1.WorkerService).
#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "channel_security.h"
#include "coordinator_link.h"
#include "lensfarm/v1/worker_service.grpc.pb.h"

namespace lensfarm {

class GrpcCoordinatorLink final : public CoordinatorLink {
 public:
  GrpcCoordinatorLink(std::shared_ptr<grpc::Channel> channel, ChannelSecurity security, double callTimeoutSeconds = 30.0);

  Registration registerWorker(const WorkerInfo& info) override;
  std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds) override;
  std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds) override;
  JobSpec jobSpec(const std::string& jobId) override;
  std::string asset(const std::string& sha256) override;
  bool upload(const UnitResult& result) override;
  void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                     const std::string& error) override;

 private:
  std::unique_ptr<grpc::ClientContext> context(double extraSeconds = 0.0) const;
  std::unique_ptr<v1::WorkerService::Stub> stub_;
  ChannelSecurity security_;
  double callTimeoutSeconds_;
};

}  // namespace lensfarm
