#include "farm_client.h"

#include <chrono>

#include "convert.h"

namespace lensfarm::cli {

namespace {
void check(const grpc::Status& s, const std::string& address) {
  if (s.ok()) return;
  if (s.error_code() == grpc::StatusCode::UNAVAILABLE || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
    throw ClientError(s.error_code(), "coordinator " + address + " unreachable: " + s.error_message());
  throw ClientError(s.error_code(), s.error_message());
}
}  // namespace

FarmClient::FarmClient(const std::string& address, const ChannelSecurity& security, double timeoutSeconds)
    : address_(address),
      security_(security),
      timeout_(timeoutSeconds),
      stub_(v1::ClientService::NewStub(makeChannel(address, security))) {}

std::unique_ptr<grpc::ClientContext> FarmClient::context(bool streaming) const {
  auto c = std::make_unique<grpc::ClientContext>();
  if (!streaming)
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(int64_t(timeout_ * 1000)));
  c->set_wait_for_ready(false);
  authorize(*c, security_);
  return c;
}

v1::SubmitJobResponse FarmClient::submit(const LocalJob& job, int priority) {
  for (const auto& [sha, bytes] : job.assetBytes) {
    auto ctx = context(true);
    v1::UploadAssetResponse response;
    auto writer = stub_->UploadAsset(ctx.get(), &response);
    size_t offset = 0;
    do {
      v1::UploadAssetRequest message;
      if (offset == 0) {
        message.set_sha256(sha);
        message.mutable_chunk()->set_total_size(bytes.size());
      }
      const size_t n = std::min(proto::kChunkBytes, bytes.size() - offset);
      message.mutable_chunk()->set_data(bytes.data() + offset, n);
      if (!writer->Write(message)) break;
      offset += n;
    } while (offset < bytes.size());
    writer->WritesDone();
    check(writer->Finish(), address_);
  }
  v1::SubmitJobRequest request;
  *request.mutable_spec() = proto::toProto(job.spec);
  request.set_priority(priority);
  v1::SubmitJobResponse response;
  check(stub_->SubmitJob(context().get(), request, &response), address_);
  return response;
}

v1::JobStatus FarmClient::get(const std::string& jobId) {
  v1::GetJobRequest request;
  request.set_job_id(jobId);
  v1::JobStatus response;
  check(stub_->GetJob(context().get(), request, &response), address_);
  return response;
}

std::vector<v1::JobStatus> FarmClient::list() {
  v1::ListJobsResponse response;
  check(stub_->ListJobs(context().get(), v1::ListJobsRequest{}, &response), address_);
  return {response.jobs().begin(), response.jobs().end()};
}

v1::JobStatus FarmClient::watch(const std::string& jobId, const std::function<void(const v1::JobStatus&)>& onStatus) {
  v1::WatchJobRequest request;
  request.set_job_id(jobId);
  auto ctx = context(true);
  auto reader = stub_->WatchJob(ctx.get(), request);
  v1::JobStatus status, last;
  while (reader->Read(&status)) {
    onStatus(status);
    last = status;
  }
  check(reader->Finish(), address_);
  return last;
}

std::string FarmClient::download(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev) {
  v1::DownloadRequest request;
  request.set_job_id(jobId);
  request.set_format(format);
  if (ev) request.set_ev(*ev);
  auto ctx = context(true);
  auto reader = stub_->Download(ctx.get(), request);
  v1::FileChunk chunk;
  std::string bytes;
  while (reader->Read(&chunk)) bytes += chunk.data();
  check(reader->Finish(), address_);
  return bytes;
}

v1::Snapshot FarmClient::snapshot(const std::string& jobId, uint32_t maxSize, std::optional<double> ev) {
  v1::SnapshotRequest request;
  request.set_job_id(jobId);
  request.set_max_size(maxSize);
  if (ev) request.set_ev(*ev);
  v1::Snapshot response;
  check(stub_->GetSnapshot(context().get(), request, &response), address_);
  return response;
}

v1::JobStatus FarmClient::cancel(const std::string& jobId) {
  v1::CancelJobRequest request;
  request.set_job_id(jobId);
  v1::CancelJobResponse response;
  check(stub_->CancelJob(context().get(), request, &response), address_);
  return response.status();
}

std::vector<v1::WorkerStatus> FarmClient::workers() {
  v1::ListWorkersResponse response;
  check(stub_->ListWorkers(context().get(), v1::ListWorkersRequest{}, &response), address_);
  return {response.workers().begin(), response.workers().end()};
}

}  // namespace lensfarm::cli
