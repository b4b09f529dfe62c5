#include "worker/grpc_link.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "proto/convert.h"

namespace lensfarm {

namespace {
// Maps a failed call to the link's exceptions (see coordinator_link.h).
[[noreturn]] void raise(const grpc::Status& status, const char* rpc) {
  const std::string what = std::string(rpc) + ": " + status.error_message();
  switch (status.error_code()) {
    case grpc::StatusCode::NOT_FOUND:
      if (status.error_message().rfind("unknown worker", 0) == 0)
        throw FarmError(FarmError::Kind::kUnknownWorker, what);
      throw FarmError(FarmError::Kind::kNotFound, what);
    case grpc::StatusCode::FAILED_PRECONDITION: throw FarmError(FarmError::Kind::kFailedPrecondition, what);
    case grpc::StatusCode::INVALID_ARGUMENT: throw FarmError(FarmError::Kind::kInvalidArgument, what);
    case grpc::StatusCode::UNAUTHENTICATED:
    case grpc::StatusCode::PERMISSION_DENIED: throw FarmError(FarmError::Kind::kUnauthenticated, what);
    default: throw LinkUnavailable(what + " (" + std::to_string(int(status.error_code())) + ")");
  }
}
}  // namespace

GrpcCoordinatorLink::GrpcCoordinatorLink(std::shared_ptr<grpc::Channel> channel, ChannelSecurity security,
                                         double callTimeoutSeconds)
    : stub_(v1::WorkerService::NewStub(channel)),
      security_(std::move(security)),
      callTimeoutSeconds_(callTimeoutSeconds) {}

std::unique_ptr<grpc::ClientContext> GrpcCoordinatorLink::context(double extraSeconds) const {
  auto c = std::make_unique<grpc::ClientContext>();
  c->set_deadline(std::chrono::system_clock::now() +
                  std::chrono::milliseconds(int64_t((callTimeoutSeconds_ + extraSeconds) * 1000)));
  authorize(*c, security_);
  return c;
}

Registration GrpcCoordinatorLink::registerWorker(const WorkerInfo& info) {
  v1::RegisterRequest request;
  request.set_name(info.name);
  request.set_threads(info.threads);
  request.set_protocol_version(info.protocolVersion);
  request.set_renderer_version(info.rendererVersion);
  request.set_max_unit_memory_bytes(info.maxUnitMemoryBytes);
  for (const std::string& k : info.kernels) request.add_kernels(k);
  for (const std::string& t : info.tags) request.add_tags(t);
  request.set_build(info.build);
  request.set_cpu(info.cpu);
  v1::RegisterResponse response;
  const grpc::Status s = stub_->Register(context().get(), request, &response);
  if (!s.ok()) raise(s, "Register");
  {
    std::lock_guard lock(sessionMutex_);
    session_ = response.session();
    sessionWorker_ = response.worker_id();
  }
  attachAs(response.worker_id());
  return Registration{response.worker_id(), std::max(0.01, response.heartbeat_interval_ms() / 1000.0)};
}

std::string GrpcCoordinatorLink::session() const {
  std::lock_guard lock(sessionMutex_);
  return session_;
}

// ---- the Attach stream ----------------------------------------------------------------------

GrpcCoordinatorLink::~GrpcCoordinatorLink() { stopAttaching(); }

void GrpcCoordinatorLink::stopAttaching() {
  {
    std::lock_guard lock(attachMutex_);
    attachStop_ = true;
    if (attachContext_) attachContext_->TryCancel();
  }
  attachWake_.notify_all();
  if (attacher_.joinable()) attacher_.join();
}

void GrpcCoordinatorLink::attachAs(const std::string& workerId) {
  std::lock_guard lock(attachMutex_);
  if (attachStop_) return;
  if (attachId_ != workerId) {
    attachId_ = workerId;
    if (attachContext_) attachContext_->TryCancel();  // a stream for an id the coordinator forgot
  }
  if (!attacher_.joinable()) attacher_ = std::thread([this] { attachLoop(); });
  attachWake_.notify_all();
}

bool GrpcCoordinatorLink::attached() {
  std::lock_guard lock(attachMutex_);
  return attachStream_ != nullptr;
}

void GrpcCoordinatorLink::attachLoop() {
  double backoff = 0.0;
  std::unique_lock lock(attachMutex_);
  while (!attachStop_) {
    if (attachId_.empty() || attachId_ == refusedId_) {
      attachWake_.wait(lock);
      continue;
    }
    const std::string id = attachId_;
    grpc::ClientContext ctx;  // no deadline: the stream lasts as long as the worker
    authorize(ctx, security_);
    attachContext_ = &ctx;
    lock.unlock();
    auto stream = stub_->Attach(&ctx);
    v1::AttachRequest hello;
    hello.set_worker_id(id);
    hello.set_session(session());
    v1::AttachEvent event;
    if (stream->Write(hello) && stream->Read(&event) && event.attached()) {
      spdlog::debug("attached to the coordinator as {}", id);
      backoff = 0.0;
      lock.lock();
      attachStream_ = stream.get();
      lock.unlock();
      while (stream->Read(&event)) {
      }
      lock.lock();
      attachStream_ = nullptr;
      attachWake_.notify_all();  // leave() waits for this
      lock.unlock();
    }
    const grpc::Status status = stream->Finish();
    lock.lock();
    attachContext_ = nullptr;
    if (attachStop_) break;
    switch (status.error_code()) {
      case grpc::StatusCode::UNIMPLEMENTED:  // an older coordinator: heartbeats and lease timeouts only
        spdlog::info("the coordinator does not offer Attach; it will notice this worker's loss by its lease timeout");
        refusedId_ = id;
        break;
      case grpc::StatusCode::NOT_FOUND:  // it forgot this id (a restart, or it judged us lost): register first
      case grpc::StatusCode::UNAUTHENTICATED:
      case grpc::StatusCode::PERMISSION_DENIED:
        spdlog::debug("Attach as {}: {}", id, status.error_message());
        refusedId_ = id;
        break;
      default:  // the connection broke or the coordinator is going away: try again, backing off
        if (attachId_ != id) break;
        backoff = std::min(5.0, backoff > 0.0 ? backoff * 2 : 0.1);
        spdlog::debug("Attach as {} ended: {}; again in {:.1f} s", id, status.error_message(), backoff);
        attachWake_.wait_for(lock, std::chrono::duration<double>(backoff),
                             [&] { return attachStop_ || attachId_ != id; });
    }
  }
}

void GrpcCoordinatorLink::leave() {
  {
    std::unique_lock lock(attachMutex_);
    if (attachStream_) {
      v1::AttachRequest bye;
      bye.set_leaving(true);
      // Under the lock: the attach thread cannot finish the stream meanwhile.
      if (attachStream_->Write(bye)) attachStream_->WritesDone();
      attachWake_.wait_for(lock, std::chrono::seconds(2), [&] { return attachStream_ == nullptr; });
    }
  }
  stopAttaching();
}

std::vector<uint64_t> GrpcCoordinatorLink::heartbeat(const std::string& workerId,
                                                     const std::vector<uint64_t>& leaseIds) {
  v1::HeartbeatRequest request;
  request.set_worker_id(workerId);
  request.set_session(session());
  for (uint64_t id : leaseIds) request.add_lease_ids(id);
  v1::HeartbeatResponse response;
  const grpc::Status s = stub_->Heartbeat(context().get(), request, &response);
  if (!s.ok()) raise(s, "Heartbeat");
  return {response.revoked_lease_ids().begin(), response.revoked_lease_ids().end()};
}

std::optional<LeaseGrant> GrpcCoordinatorLink::lease(const std::string& workerId, double waitSeconds) {
  v1::LeaseWorkRequest request;
  request.set_worker_id(workerId);
  request.set_session(session());
  request.set_wait_ms(uint32_t(waitSeconds * 1000));
  v1::LeaseWorkResponse response;
  const grpc::Status s = stub_->LeaseWork(context(waitSeconds).get(), request, &response);
  if (!s.ok()) raise(s, "LeaseWork");
  if (!response.has_lease()) {
    prefetch_ = response.prefetch_job_id();
    return std::nullopt;
  }
  return proto::fromProto(response.lease());
}

JobSpec GrpcCoordinatorLink::jobSpec(const std::string& jobId) {
  v1::GetJobSpecRequest request;
  request.set_job_id(jobId);
  {
    std::lock_guard lock(sessionMutex_);
    request.set_worker_id(sessionWorker_);
    request.set_session(session_);
  }
  v1::JobSpec response;
  const grpc::Status s = stub_->GetJobSpec(context().get(), request, &response);
  if (!s.ok()) raise(s, "GetJobSpec");
  return proto::fromProto(response);
}

std::string GrpcCoordinatorLink::asset(const std::string& sha256) {
  v1::FetchAssetRequest request;
  request.set_sha256(sha256);
  {
    std::lock_guard lock(sessionMutex_);
    request.set_worker_id(sessionWorker_);
    request.set_session(session_);
  }
  auto ctx = context(600.0);
  auto reader = stub_->FetchAsset(ctx.get(), request);
  v1::FileChunk chunk;
  std::string bytes;
  while (reader->Read(&chunk)) bytes += chunk.data();
  const grpc::Status s = reader->Finish();
  if (!s.ok()) raise(s, "FetchAsset");
  return bytes;
}

bool GrpcCoordinatorLink::upload(const UnitResult& result) {
  auto ctx = context(600.0);
  v1::UploadResultResponse response;
  auto writer = stub_->UploadResult(ctx.get(), &response);
  // Raw: pieces of 1 MiB. Shuffle + zstd: one block of kSumsBlockDoubles (512 KiB decoded, at most
  // 514 KiB encoded) a piece (worker_service.proto, SumsEncoding).
  const bool compress = result.uploadEncoding == SumsEncoding::kShuffleZstd;
  const size_t perChunk = compress ? kSumsBlockDoubles : proto::kChunkBytes / sizeof(double);
  const std::vector<double>& sums = result.buffer.sums;
  size_t offset = 0;
  do {
    v1::UploadResultRequest message;
    if (offset == 0) {
      auto* h = message.mutable_header();
      h->set_worker_id(result.workerId);
      h->set_session(session());
      h->set_lease_id(result.leaseId);
      h->set_job_id(result.jobId);
      h->set_unit_index(result.unitIndex);
      h->set_width(uint32_t(result.buffer.width));
      h->set_height(uint32_t(result.buffer.height));
      if (result.buffer.channels != 3) h->set_channels(uint32_t(result.buffer.channels));
      *h->mutable_stats() = proto::toProto(result.stats, result.renderSeconds);
      h->set_encoding(compress ? v1::SUMS_ENCODING_SHUFFLE_ZSTD : v1::SUMS_ENCODING_RAW);
      h->set_kernel(result.kernel);
    }
    const size_t n = std::min(perChunk, sums.size() - offset);
    message.set_offset(offset);
    if (compress)
      message.set_sums(encodeSumsBlock(sums.data() + offset, n));
    else
      message.set_sums(reinterpret_cast<const char*>(sums.data() + offset), n * sizeof(double));
    if (!writer->Write(message)) break;  // the server ended the call; Finish() says why
    offset += n;
  } while (offset < sums.size());
  writer->WritesDone();
  const grpc::Status s = writer->Finish();
  if (!s.ok()) raise(s, "UploadResult");
  return response.accepted();
}

void GrpcCoordinatorLink::reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                                        const std::string& error) {
  v1::ReportFailureRequest request;
  request.set_worker_id(workerId);
  request.set_session(session());
  request.set_lease_id(leaseId);
  request.set_job_id(jobId);
  request.set_error(error);
  v1::ReportFailureResponse response;
  const grpc::Status s = stub_->ReportFailure(context().get(), request, &response);
  if (!s.ok()) raise(s, "ReportFailure");
}

}  // namespace lensfarm
