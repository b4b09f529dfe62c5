#include "client/farm_client.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <optional>

#include "common/util/atomic_file.h"

#include "coordinator/core/coordinator.h"
#include "proto/convert.h"

namespace lensfarm::cli {

namespace {
bool mentions(const std::string& text, const char* part) { return text.find(part) != std::string::npos; }

// A failure that says the peer is not a lensfarm coordinator (an HTTP server such as the
// dashboard, another gRPC service), as a sentence; nothing for a coordinator's own answer.
std::optional<std::string> wrongServer(const grpc::Status& s, const std::string& address) {
  const std::string& m = s.error_message();
  const std::string hint =
      " (the coordinator's gRPC port is its --listen, 7878 by default; its dashboard and metrics "
      "ports serve HTTP to browsers)";
  if (mentions(m, "http1.x") || mentions(m, "HTTP/1") || mentions(m, "Received http2 header with status") ||
      mentions(m, "Bad Request") || mentions(m, "received initial metadata size exceeds limit"))
    return "coordinator " + address + ": an HTTP server answered, not a lensfarm coordinator" + hint;
  if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED && !mentions(m, "lensfarm"))
    return "coordinator " + address +
           ": a gRPC server answered that is not a lensfarm coordinator (it does not know "
           "the lensfarm.v1.ClientService)" +
           hint;
  return std::nullopt;
}

void check(const grpc::Status& s, const std::string& address) {
  if (s.ok()) return;
  // Not a coordinator: the farm is unreachable at that address (exit code 3), whatever the code.
  if (const std::optional<std::string> wrong = wrongServer(s, address))
    throw ClientError(grpc::StatusCode::UNAVAILABLE, *wrong);
  if (s.error_code() == grpc::StatusCode::UNAVAILABLE || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
    const std::string& m = s.error_message();
    if (mentions(m, "Connection refused") || mentions(m, "connection refused"))
      throw ClientError(s.error_code(), "coordinator " + address +
                                            " unreachable: nothing listens on that port (is the "
                                            "coordinator running, and is this its --listen address?)");
    if (mentions(m, "DNS resolution failed") || mentions(m, "Name or service not known"))
      throw ClientError(s.error_code(), "coordinator " + address + " unreachable: the host name does not resolve");
    if (s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
      throw ClientError(s.error_code(), "coordinator " + address +
                                            " did not answer in time (a firewall, a wrong host, "
                                            "or a TLS coordinator without --tls-ca?)");
    throw ClientError(s.error_code(), "coordinator " + address + " unreachable: " + m);
  }
  throw ClientError(s.error_code(), s.error_message());
}

// A coordinator address is HOST:PORT for gRPC; a URL scheme in front is a common slip.
const std::string& checkedAddress(const std::string& address) {
  for (const char* scheme : {"http://", "https://", "grpc://", "grpcs://"})
    if (address.rfind(scheme, 0) == 0)
      throw ClientError(grpc::StatusCode::INVALID_ARGUMENT,
                        "--coordinator \"" + address + "\": give HOST:PORT without \"" + scheme +
                            "\" (lensfarm speaks gRPC, not HTTP; for TLS give --tls-ca), e.g. --coordinator " +
                            address.substr(std::string(scheme).size()));
  return address;
}
}  // namespace

FarmClient::FarmClient(const std::string& address, const ChannelSecurity& security, double timeoutSeconds)
    : address_(checkedAddress(address)),
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

std::optional<std::set<std::string>> FarmClient::missingAssets(const std::vector<std::string>& hashes) {
  std::set<std::string> missing;
  for (size_t first = 0; first < hashes.size(); first += Coordinator::kMaxAssetQuery) {
    v1::FindMissingAssetsRequest request;
    for (size_t i = first; i < std::min(hashes.size(), first + Coordinator::kMaxAssetQuery); ++i)
      request.add_sha256(hashes[i]);
    v1::FindMissingAssetsResponse response;
    const grpc::Status s = stub_->FindMissingAssets(context().get(), request, &response);
    if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED) return std::nullopt;
    check(s, address_);
    missing.insert(response.missing_sha256().begin(), response.missing_sha256().end());
  }
  return missing;
}

bool FarmClient::uploadAsset(const std::string& sha256, const std::string& bytes) {
  auto ctx = context(true);
  v1::UploadAssetResponse response;
  auto writer = stub_->UploadAsset(ctx.get(), &response);
  size_t offset = 0;
  do {
    v1::UploadAssetRequest message;
    if (offset == 0) {
      message.set_sha256(sha256);
      message.mutable_chunk()->set_total_size(bytes.size());
    }
    const size_t n = std::min(proto::kChunkBytes, bytes.size() - offset);
    message.mutable_chunk()->set_data(bytes.data() + offset, n);
    // A failed write means the call has ended: the coordinator may have answered already_present
    // after the first message without reading on. Finish says whether that was it or an error.
    if (!writer->Write(message)) break;
    offset += n;
  } while (offset < bytes.size());
  writer->WritesDone();
  check(writer->Finish(), address_);
  return response.already_present();
}

void FarmClient::uploadAssets(const std::map<std::string, std::string>& assetBytes) {
  if (assetBytes.empty()) return;
  std::vector<std::string> hashes;
  for (const auto& entry : assetBytes) hashes.push_back(entry.first);
  const std::optional<std::set<std::string>> missing = missingAssets(hashes);
  if (!missing)
    spdlog::info("coordinator {} cannot say which assets it holds (no FindMissingAssets): uploading all {}", address_,
                 assetBytes.size());
  uint64_t uploaded = 0, uploadedBytes = 0, skipped = 0, skippedBytes = 0;
  for (const auto& [sha, bytes] : assetBytes) {
    const bool present = (missing && !missing->count(sha)) || uploadAsset(sha, bytes);
    ++(present ? skipped : uploaded);
    (present ? skippedBytes : uploadedBytes) += bytes.size();
  }
  spdlog::info("assets: {} uploaded ({:.2f} MB), {} skipped, already on the coordinator ({:.2f} MB)", uploaded,
               double(uploadedBytes) / 1e6, skipped, double(skippedBytes) / 1e6);
}

v1::SubmitJobResponse FarmClient::submit(const LocalJob& job, int priority, const std::string& owner,
                                         const JobPolicy& policy, bool paused) {
  uploadAssets(job.assetBytes);
  v1::SubmitJobRequest request;
  *request.mutable_spec() = proto::toProto(job.spec);
  request.set_priority(priority);
  request.set_owner(owner);
  *request.mutable_policy() = proto::toProto(policy);
  request.set_paused(paused);
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

std::vector<v1::JobStatus> FarmClient::list(const v1::ListJobsRequest& filters) {
  v1::ListJobsResponse response;
  check(stub_->ListJobs(context().get(), filters, &response), address_);
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

std::string FarmClient::download(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev,
                                 std::optional<int64_t> frame) {
  v1::DownloadRequest request;
  request.set_job_id(jobId);
  request.set_format(format);
  if (ev) request.set_ev(*ev);
  if (frame) request.set_frame(*frame);
  auto ctx = context(true);
  auto reader = stub_->Download(ctx.get(), request);
  v1::FileChunk chunk;
  std::string bytes;
  while (reader->Read(&chunk)) bytes += chunk.data();
  check(reader->Finish(), address_);
  return bytes;
}

void FarmClient::downloadTo(const std::string& jobId, v1::ImageFormat format, std::optional<double> ev,
                            std::optional<int64_t> frame, const std::filesystem::path& file) {
  v1::DownloadRequest request;
  request.set_job_id(jobId);
  request.set_format(format);
  if (ev) request.set_ev(*ev);
  if (frame) request.set_frame(*frame);
  // The coordinator's refusal leaves no file and keeps its own error (and exit code): it passes
  // writeFileAtomically as a type it does not wrap.
  struct Refused {
    grpc::Status status;
  };
  try {
    writeFileAtomically(file, [&](const std::filesystem::path& tmp) {
      std::ofstream out(tmp, std::ios::binary);
      if (!out) throw std::runtime_error("cannot create " + tmp.string());
      auto ctx = context(true);
      auto reader = stub_->Download(ctx.get(), request);
      v1::FileChunk chunk;
      while (reader->Read(&chunk))
        if (!out.write(chunk.data().data(), std::streamsize(chunk.data().size()))) {
          ctx->TryCancel();
          reader->Finish();
          throw std::runtime_error("write failed");
        }
      if (grpc::Status s = reader->Finish(); !s.ok()) throw Refused{s};
      out.close();
      if (!out) throw std::runtime_error("write failed");
    });
  } catch (const Refused& r) {
    check(r.status, address_);
  }
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

v1::JobStatus FarmClient::pause(const std::string& jobId) {
  return jobAction(&v1::ClientService::Stub::PauseJob, jobId);
}
v1::JobStatus FarmClient::resume(const std::string& jobId) {
  return jobAction(&v1::ClientService::Stub::ResumeJob, jobId);
}
v1::JobStatus FarmClient::approve(const std::string& jobId) {
  return jobAction(&v1::ClientService::Stub::ApproveJob, jobId);
}
v1::JobStatus FarmClient::prefetch(const std::string& jobId) {
  return jobAction(&v1::ClientService::Stub::PrefetchJob, jobId);
}

v1::JobStatus FarmClient::update(const v1::UpdateJobRequest& request) {
  v1::JobActionResponse response;
  check(stub_->UpdateJob(context().get(), request, &response), address_);
  return response.status();
}

v1::ListEventsResponse FarmClient::events(const v1::ListEventsRequest& request) {
  v1::ListEventsResponse response;
  // (the call's deadline covers the long poll)
  auto ctx = context(true);
  ctx->set_deadline(std::chrono::system_clock::now() +
                    std::chrono::milliseconds(int64_t(1000 * (timeout_ + request.wait_seconds()))));
  check(stub_->ListEvents(ctx.get(), request, &response), address_);
  return response;
}

v1::JobStatus FarmClient::jobAction(JobAction call, const std::string& jobId) {
  v1::JobActionRequest request;
  request.set_job_id(jobId);
  v1::JobActionResponse response;
  check(((*stub_).*call)(context().get(), request, &response), address_);
  return response.status();
}

void FarmClient::deleteJob(const std::string& jobId, bool force) {
  v1::DeleteJobRequest request;
  request.set_job_id(jobId);
  request.set_force(force);
  v1::DeleteJobResponse response;
  check(stub_->DeleteJob(context().get(), request, &response), address_);
}

v1::JobStatus FarmClient::archive(const std::string& jobId) {
  v1::ArchiveJobRequest request;
  request.set_job_id(jobId);
  v1::ArchiveJobResponse response;
  // No deadline: archiving writes the whole image (minutes for a 16384² one), and ends either way.
  check(stub_->ArchiveJob(context(true).get(), request, &response), address_);
  return response.status();
}

std::vector<v1::WorkerStatus> FarmClient::workers() {
  v1::ListWorkersResponse response;
  check(stub_->ListWorkers(context().get(), v1::ListWorkersRequest{}, &response), address_);
  return {response.workers().begin(), response.workers().end()};
}

}  // namespace lensfarm::cli
