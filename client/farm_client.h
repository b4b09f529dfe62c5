#pragma once
// The client side of lensfarm.v1.ClientService, for the CLI's farm commands.
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "channel_security.h"
#include "job_spec.h"
#include "lensfarm/v1/client_service.grpc.pb.h"

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

  // Uploads the job's assets (skipping none: the coordinator dedupes by hash) and submits it.
  v1::SubmitJobResponse submit(const LocalJob& job, int priority);
  v1::JobStatus get(const std::string& jobId);
  std::vector<v1::JobStatus> list();
  // Calls `onStatus` for every status the coordinator sends; returns the last one.
  v1::JobStatus watch(const std::string& jobId, const std::function<void(const v1::JobStatus&)>& onStatus);
  std::string download(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev);
  v1::Snapshot snapshot(const std::string& jobId, uint32_t maxSize, std::optional<double> ev);
  v1::JobStatus cancel(const std::string& jobId);
  std::vector<v1::WorkerStatus> workers();

 private:
  std::unique_ptr<grpc::ClientContext> context(bool streaming = false) const;
  std::string address_;
  ChannelSecurity security_;
  double timeout_;
  std::unique_ptr<v1::ClientService::Stub> stub_;
};

}  // namespace lensfarm::cli
