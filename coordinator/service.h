#pragma once
// The coordinator's gRPC services: thin handlers that translate lensfarm.v1 messages and status
// codes and call Coordinator (coordinator.h), in the style of gRPC's route_guide example.
#include <grpcpp/grpcpp.h>

#include "auth.h"
#include "coordinator.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "lensfarm/v1/worker_service.grpc.pb.h"

namespace lensfarm {

class ClientServiceImpl final : public v1::ClientService::Service {
 public:
  ClientServiceImpl(Coordinator& coordinator, TokenGate gate = TokenGate({}, "client"))
      : coordinator_(coordinator), gate_(std::move(gate)) {}

  grpc::Status UploadAsset(grpc::ServerContext* context, grpc::ServerReader<v1::UploadAssetRequest>* reader,
                           v1::UploadAssetResponse* response) override;
  grpc::Status SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request, v1::SubmitJobResponse* response) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::JobStatus* response) override;
  grpc::Status ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest*, v1::ListJobsResponse* response) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                        grpc::ServerWriter<v1::JobStatus>* writer) override;
  grpc::Status Download(grpc::ServerContext* context, const v1::DownloadRequest* request,
                        grpc::ServerWriter<v1::FileChunk>* writer) override;
  grpc::Status GetSnapshot(grpc::ServerContext* context, const v1::SnapshotRequest* request, v1::Snapshot* response) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request, v1::CancelJobResponse* response) override;
  grpc::Status ListWorkers(grpc::ServerContext* context, const v1::ListWorkersRequest*, v1::ListWorkersResponse* response) override;

 private:
  Coordinator& coordinator_;
  TokenGate gate_;
};

class WorkerServiceImpl final : public v1::WorkerService::Service {
 public:
  WorkerServiceImpl(Coordinator& coordinator, TokenGate gate = TokenGate({}, "worker"))
      : coordinator_(coordinator), gate_(std::move(gate)) {}

  grpc::Status Register(grpc::ServerContext* context, const v1::RegisterRequest* request, v1::RegisterResponse* response) override;
  grpc::Status Heartbeat(grpc::ServerContext* context, const v1::HeartbeatRequest* request, v1::HeartbeatResponse* response) override;
  grpc::Status LeaseWork(grpc::ServerContext* context, const v1::LeaseWorkRequest* request, v1::LeaseWorkResponse* response) override;
  grpc::Status GetJobSpec(grpc::ServerContext* context, const v1::GetJobSpecRequest* request, v1::JobSpec* response) override;
  grpc::Status FetchAsset(grpc::ServerContext* context, const v1::FetchAssetRequest* request,
                          grpc::ServerWriter<v1::FileChunk>* writer) override;
  grpc::Status UploadResult(grpc::ServerContext* context, grpc::ServerReader<v1::UploadResultRequest>* reader,
                            v1::UploadResultResponse* response) override;
  grpc::Status ReportFailure(grpc::ServerContext* context, const v1::ReportFailureRequest* request,
                             v1::ReportFailureResponse*) override;

 private:
  Coordinator& coordinator_;
  TokenGate gate_;
};

// JobInfo as the wire's JobStatus.
v1::JobStatus toProto(const JobInfo& info);

}  // namespace lensfarm
