#pragma once
// CoordinatorLink over gRPC (lensfarm.v1.WorkerService).
#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "lensfarm/v1/worker_service.grpc.pb.h"
#include "proto/channel_security.h"
#include "worker/coordinator_link.h"

namespace lensfarm {

// From its first successful registration on, the link holds the worker's Attach stream
// (worker_service.proto) on a thread of its own, re-opening it after a break (backing off) and
// re-targeting it when the worker registers again under a new id. A coordinator without Attach
// (UNIMPLEMENTED) is left to judge the worker by heartbeats. Destroying the link without leave()
// drops the stream: the coordinator then sees the worker as lost.
class GrpcCoordinatorLink final : public CoordinatorLink {
 public:
  GrpcCoordinatorLink(std::shared_ptr<grpc::Channel> channel, ChannelSecurity security,
                      double callTimeoutSeconds = 30.0);
  ~GrpcCoordinatorLink() override;

  Registration registerWorker(const WorkerInfo& info) override;
  std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds) override;
  std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds) override;
  std::string takePrefetch() override { return std::exchange(prefetch_, std::string()); }
  JobSpec jobSpec(const std::string& jobId) override;
  std::string asset(const std::string& sha256) override;
  bool upload(const UnitResult& result) override;
  void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                     const std::string& error) override;
  // Says `leaving` on the Attach stream and waits (at most 2 s) for the coordinator to end it.
  void leave() override;
  // Whether the Attach stream is open and acknowledged now (for tests and logs).
  bool attached();

 private:
  std::unique_ptr<grpc::ClientContext> context(double extraSeconds = 0.0) const;
  // The session of the current registration (RegisterResponse.session), quoted in every call.
  std::string session() const;
  mutable std::mutex sessionMutex_;
  std::string session_, sessionWorker_;  // and the worker id it is for
  void attachAs(const std::string& workerId);
  void attachLoop();
  void stopAttaching();
  std::unique_ptr<v1::WorkerService::Stub> stub_;
  std::string prefetch_;  // the last LeaseWork's prefetch_job_id (the worker loop's thread only)
  ChannelSecurity security_;
  double callTimeoutSeconds_;

  std::mutex attachMutex_;
  std::condition_variable attachWake_;
  std::thread attacher_;
  std::string attachId_;   // the worker id to attach as; empty: not registered yet
  std::string refusedId_;  // an id the coordinator refused (unknown, or no Attach): wait for another
  grpc::ClientContext* attachContext_ = nullptr;                                          // the open call, to cancel it
  grpc::ClientReaderWriter<v1::AttachRequest, v1::AttachEvent>* attachStream_ = nullptr;  // once acknowledged
  bool attachStop_ = false;
};

}  // namespace lensfarm
