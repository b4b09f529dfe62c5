#pragma once
// The client side of lensfarm.v1.ClientService, for the CLI's farm commands.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/job_spec.h"
#include "common/farm/job_policy.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "proto/channel_security.h"

namespace lensfarm::cli {

// A failed call: the gRPC status code and the coordinator's message.
class ClientError : public std::runtime_error {
 public:
  ClientError(grpc::StatusCode code, const std::string& what) : std::runtime_error(what), code_(code) {}
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

class FarmClient {
 public:
  FarmClient(const std::string& address, const ChannelSecurity& security, double timeoutSeconds = 30.0);

  // Uploads the job's assets the coordinator does not hold (FindMissingAssets; every one for a
  // coordinator older than it) and submits the job. Logs how many assets and bytes were uploaded
  // and how many were skipped as already on the coordinator.
  v1::SubmitJobResponse submit(const LocalJob& job, int priority, const std::string& owner = "",
                               const JobPolicy& policy = {}, bool paused = false);
  v1::JobStatus get(const std::string& jobId);
  std::vector<v1::JobStatus> list(const v1::ListJobsRequest& filters = {});
  // Calls `onStatus` for every status the coordinator sends; returns the last one.
  v1::JobStatus watch(const std::string& jobId, const std::function<void(const v1::JobStatus&)>& onStatus);
  // `frame`: an animation's frame (a scene frame number); nullopt: the still or the first frame.
  std::string download(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev,
                       std::optional<int64_t> frame = std::nullopt);
  // The same, written into `file` as the chunks arrive (atomically: a temporary, then renamed;
  // nothing is left at `file` if the call fails), so a large image never sits in memory.
  void downloadTo(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev,
                  std::optional<int64_t> frame, const std::filesystem::path& file);
  v1::Snapshot snapshot(const std::string& jobId, uint32_t maxSize, std::optional<double> ev);
  v1::JobStatus cancel(const std::string& jobId);
  // The scheduling actions (docs/farm.md "Scheduling"): PauseJob, ResumeJob, ApproveJob.
  v1::JobStatus pause(const std::string& jobId);
  v1::JobStatus resume(const std::string& jobId);
  v1::JobStatus approve(const std::string& jobId);
  v1::JobStatus prefetch(const std::string& jobId);  // PrefetchJob
  // UpdateJob: the fields set in `request` (priority, max_workers, share_weight) change.
  v1::JobStatus update(const v1::UpdateJobRequest& request);
  // ListEvents: the farm's notifications after `request.after()` (a long poll with wait_seconds).
  v1::ListEventsResponse events(const v1::ListEventsRequest& request);
  void deleteJob(const std::string& jobId, bool force);
  v1::JobStatus archive(const std::string& jobId);
  std::vector<v1::WorkerStatus> workers();

 private:
  std::unique_ptr<grpc::ClientContext> context(bool streaming = false) const;
  using JobAction = grpc::Status (v1::ClientService::Stub::*)(grpc::ClientContext*, const v1::JobActionRequest&,
                                                              v1::JobActionResponse*);
  v1::JobStatus jobAction(JobAction call, const std::string& jobId);
  void uploadAssets(const std::map<std::string, std::string>& assetBytes);  // sha256 -> bytes
  // The hashes among `hashes` the coordinator lacks; nullopt if it cannot say (UNIMPLEMENTED).
  std::optional<std::set<std::string>> missingAssets(const std::vector<std::string>& hashes);
  // Uploads one asset; true if the coordinator had it already.
  bool uploadAsset(const std::string& sha256, const std::string& bytes);
  std::string address_;
  ChannelSecurity security_;
  double timeout_;
  std::unique_ptr<v1::ClientService::Stub> stub_;
};

}  // namespace lensfarm::cli
