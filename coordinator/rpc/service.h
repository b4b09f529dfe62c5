#pragma once
// The coordinator's gRPC services: thin handlers that translate lensfarm.v1 messages and status
// codes and call Coordinator (coordinator.h), in the style of gRPC's route_guide example.
#include <grpcpp/grpcpp.h>

#include <mutex>
#include <set>

#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/auth.h"
#include "coordinator/rpc/job_watchers.h"
#include "coordinator/rpc/role_slots.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "lensfarm/v1/worker_service.grpc.pb.h"

namespace lensfarm {

// Sync handlers, except WatchJob: a stream a client may hold for a job's life, served by gRPC's
// callback API (JobWatchers: one thread for every stream, a cap per caller role).
class ClientServiceImpl final : public v1::ClientService::WithCallbackMethod_WatchJob<v1::ClientService::Service> {
 public:
  // The most WatchJob streams one role (client token, viewer token, or anyone without a token)
  // may hold open.
  static constexpr size_t kMaxWatchStreamsPerRole = 1024;
  // The most Download streams one role may have in progress: each holds a server thread while its
  // client reads (and an image's memory, within the coordinator's budget).
  static constexpr size_t kMaxDownloadsPerRole = 16;

  ClientServiceImpl(Coordinator& coordinator, TokenGate gate = TokenGate({}, "client"),
                    size_t maxWatchStreamsPerRole = kMaxWatchStreamsPerRole,
                    size_t maxDownloadsPerRole = kMaxDownloadsPerRole)
      : coordinator_(coordinator),
        gate_(std::move(gate)),
        watchers_(coordinator, maxWatchStreamsPerRole),
        downloads_(maxDownloadsPerRole) {}

  // Ends every WatchJob stream (UNAVAILABLE) and refuses new ones: call before
  // grpc::Server::Shutdown.
  void endWatches() { watchers_.stop(); }

  grpc::Status FindMissingAssets(grpc::ServerContext* context, const v1::FindMissingAssetsRequest* request,
                                 v1::FindMissingAssetsResponse* response) override;
  grpc::Status UploadAsset(grpc::ServerContext* context, grpc::ServerReader<v1::UploadAssetRequest>* reader,
                           v1::UploadAssetResponse* response) override;
  grpc::Status SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request,
                         v1::SubmitJobResponse* response) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::JobStatus* response) override;
  grpc::Status ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest*,
                        v1::ListJobsResponse* response) override;
  grpc::ServerWriteReactor<v1::JobStatus>* WatchJob(grpc::CallbackServerContext* context,
                                                    const v1::WatchJobRequest* request) override;
  grpc::Status Download(grpc::ServerContext* context, const v1::DownloadRequest* request,
                        grpc::ServerWriter<v1::FileChunk>* writer) override;
  grpc::Status GetSnapshot(grpc::ServerContext* context, const v1::SnapshotRequest* request,
                           v1::Snapshot* response) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                         v1::CancelJobResponse* response) override;
  grpc::Status ListWorkers(grpc::ServerContext* context, const v1::ListWorkersRequest*,
                           v1::ListWorkersResponse* response) override;
  grpc::Status PauseJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                        v1::JobActionResponse* response) override;
  grpc::Status ResumeJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                         v1::JobActionResponse* response) override;
  grpc::Status ApproveJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                          v1::JobActionResponse* response) override;
  grpc::Status UpdateJob(grpc::ServerContext* context, const v1::UpdateJobRequest* request,
                         v1::JobActionResponse* response) override;
  grpc::Status PrefetchJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                           v1::JobActionResponse* response) override;
  grpc::Status ListEvents(grpc::ServerContext* context, const v1::ListEventsRequest* request,
                          v1::ListEventsResponse* response) override;
  grpc::Status DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request,
                         v1::DeleteJobResponse*) override;
  grpc::Status GetServerInfo(grpc::ServerContext* context, const v1::GetServerInfoRequest*,
                             v1::ServerInfo* response) override;
  grpc::Status ArchiveJob(grpc::ServerContext* context, const v1::ArchiveJobRequest* request,
                          v1::ArchiveJobResponse* response) override;

 private:
  // People (users.h): a user's call acts on a job only if their role allows it on that job's
  // owner (FarmError kPermissionDenied otherwise; kNotFound for an unknown job). The shared client
  // token acts on every job.
  void checkMayAct(const grpc::ServerContextBase* context, const std::string& action, const std::string& jobId) const;
  Coordinator& coordinator_;
  TokenGate gate_;
  JobWatchers watchers_;
  RoleSlots downloads_;
};

// ListJobsRequest's filters as Coordinator::JobFilter; FarmError kInvalidArgument naming an
// unknown state.
Coordinator::JobFilter jobFilterOf(const v1::ListJobsRequest& request);

class AttachReactor;

// Sync handlers, except Attach: a stream every worker holds for its life, served by gRPC's
// callback API (a reactor per stream, no thread pinned), so any number of attached workers
// costs no threads.
class WorkerServiceImpl final : public v1::WorkerService::WithCallbackMethod_Attach<v1::WorkerService::Service> {
 public:
  // `uploadEncoding`: how leases ask workers to upload their sums (Lease.sums_encoding; uploads
  // in either encoding are accepted whatever was asked).
  WorkerServiceImpl(Coordinator& coordinator, TokenGate gate = TokenGate({}, "worker"),
                    SumsEncoding uploadEncoding = SumsEncoding::kShuffleZstd)
      : coordinator_(coordinator), gate_(std::move(gate)), uploadEncoding_(uploadEncoding) {}
  ~WorkerServiceImpl() override;

  // Ends every Attach stream (UNAVAILABLE, "coordinator shutting down") without marking its
  // worker lost, and refuses new ones: call before grpc::Server::Shutdown, which would otherwise
  // wait out its deadline for these never-ending calls.
  void endAttachments();

  grpc::Status Register(grpc::ServerContext* context, const v1::RegisterRequest* request,
                        v1::RegisterResponse* response) override;
  grpc::Status Heartbeat(grpc::ServerContext* context, const v1::HeartbeatRequest* request,
                         v1::HeartbeatResponse* response) override;
  grpc::Status LeaseWork(grpc::ServerContext* context, const v1::LeaseWorkRequest* request,
                         v1::LeaseWorkResponse* response) override;
  grpc::Status GetJobSpec(grpc::ServerContext* context, const v1::GetJobSpecRequest* request,
                          v1::JobSpec* response) override;
  grpc::Status FetchAsset(grpc::ServerContext* context, const v1::FetchAssetRequest* request,
                          grpc::ServerWriter<v1::FileChunk>* writer) override;
  grpc::Status UploadResult(grpc::ServerContext* context, grpc::ServerReader<v1::UploadResultRequest>* reader,
                            v1::UploadResultResponse* response) override;
  grpc::Status ReportFailure(grpc::ServerContext* context, const v1::ReportFailureRequest* request,
                             v1::ReportFailureResponse*) override;
  grpc::ServerBidiReactor<v1::AttachRequest, v1::AttachEvent>* Attach(grpc::CallbackServerContext* context) override;

 private:
  friend class AttachReactor;
  Coordinator& coordinator_;
  TokenGate gate_;
  SumsEncoding uploadEncoding_;
  // The open Attach streams. Recursive: a stream finished by endAttachments() may end (and
  // unregister itself) on the same thread.
  std::recursive_mutex attachMutex_;
  std::set<AttachReactor*> attached_;
  bool closing_ = false;
};

// JobInfo as the wire's JobStatus, and WorkerView as its WorkerStatus (ListWorkers).
v1::JobStatus toProto(const JobInfo& info);
v1::WorkerStatus toProto(const WorkerView& worker);

}  // namespace lensfarm
