#include "coordinator/rpc/service.h"

#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/rpc/upload_assembler.h"
#include "coordinator/store/checked_file.h"
#include "proto/convert.h"

namespace lensfarm {

namespace {

// Bounds on text a worker sends that the coordinator keeps and shows.
constexpr size_t kMaxWorkerNameBytes = 256, kMaxFailureTextBytes = 4096;

// A request's exposure compensation: finite and within the scene format's range, else
// INVALID_ARGUMENT naming the field (a NaN would otherwise give a black image).
double checkedEv(double ev) {
  if (!(std::abs(ev) <= kMaxExposureEv))
    throw FarmError(FarmError::Kind::kInvalidArgument, "ev: must be a finite number of stops in [-" +
                                                           std::to_string(int(kMaxExposureEv)) + ", " +
                                                           std::to_string(int(kMaxExposureEv)) + "]");
  return ev;
}

// A FarmError's gRPC status.
grpc::Status farmStatus(const FarmError& e) {
  switch (e.kind()) {
    case FarmError::Kind::kNotFound:
    case FarmError::Kind::kUnknownWorker: return grpc::Status(grpc::StatusCode::NOT_FOUND, e.what());
    case FarmError::Kind::kInvalidArgument: return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what());
    case FarmError::Kind::kFailedPrecondition: return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, e.what());
    case FarmError::Kind::kUnauthenticated: return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, e.what());
    case FarmError::Kind::kPermissionDenied: return grpc::Status(grpc::StatusCode::PERMISSION_DENIED, e.what());
    case FarmError::Kind::kResourceExhausted: return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, e.what());
  }
  return grpc::Status(grpc::StatusCode::UNKNOWN, e.what());
}

// Runs a handler body and maps the project's exceptions to gRPC status codes.
template <class Body>
grpc::Status guarded(const TokenGate& gate, const grpc::ServerContext* context, const char* rpc, Body&& body) {
  if (grpc::Status s = gate.check(context, rpc); !s.ok()) return s;
  try {
    body();
    return grpc::Status::OK;
  } catch (const InputError& e) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what());
  } catch (const FarmError& e) {
    return farmStatus(e);
  } catch (const StorageError& e) {  // the disk's, not the request's: never the state dir's path
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, std::string(rpc) + ": the coordinator cannot write its state (" +
                                                           std::strerror(e.code()) + "); try again later");
  } catch (const std::bad_alloc&) {  // this request only: the coordinator goes on
    spdlog::error("{}: out of memory", rpc);
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, std::string(rpc) + ": the coordinator ran out of memory");
  } catch (const std::exception& e) {
    spdlog::error("{}: internal error: {}", rpc, e.what());
    return grpc::Status(grpc::StatusCode::INTERNAL, std::string(rpc) + ": " + e.what());
  }
}

v1::JobState toProto(JobState s) {
  switch (s) {
    case JobState::kQueued: return v1::JOB_STATE_QUEUED;
    case JobState::kRunning: return v1::JOB_STATE_RUNNING;
    case JobState::kDone: return v1::JOB_STATE_DONE;
    case JobState::kCancelled: return v1::JOB_STATE_CANCELLED;
    case JobState::kFailed: return v1::JOB_STATE_FAILED;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

// Sends `bytes` in pieces of at most kChunkBytes.
template <class Writer>
void writeChunks(Writer* writer, const std::string& bytes) {
  size_t offset = 0;
  do {
    v1::FileChunk chunk;
    if (offset == 0) chunk.set_total_size(bytes.size());
    const size_t n = std::min(proto::kChunkBytes, bytes.size() - offset);
    chunk.set_data(bytes.data() + offset, n);
    if (!writer->Write(chunk)) return;  // the client went away
    offset += n;
  } while (offset < bytes.size());
}

// Sends `size` bytes of `in`, from where it is, in pieces of at most kChunkBytes.
template <class Writer>
void writeChunks(Writer* writer, std::istream& in, uint64_t size) {
  std::string buffer(proto::kChunkBytes, '\0');
  uint64_t sent = 0;
  do {
    v1::FileChunk chunk;
    if (sent == 0) chunk.set_total_size(size);
    const size_t n = size_t(std::min<uint64_t>(buffer.size(), size - sent));
    if (!in.read(buffer.data(), std::streamsize(n)))
      throw std::runtime_error("Download: the image's file could not be read back");
    chunk.set_data(buffer.data(), n);
    if (!writer->Write(chunk)) return;  // the client went away
    sent += n;
  } while (sent < size);
}

// An EXR larger than this is written to a spool file and streamed from it, not encoded in memory.
constexpr uint64_t kSpoolAboveBytes = uint64_t(64) << 20;

// A file in `dir` that disappears when closed (unlinked at once): the download's EXR, written
// scanline by scanline from the image and read back in chunks, so no encoded copy is in memory.
std::fstream openSpool(const std::filesystem::path& dir) {
  std::string name = (dir / ".download-XXXXXX").string();
  const int fd = ::mkstemp(name.data());
  if (fd < 0) throw StorageError(name, errno);
  std::fstream spool(name, std::ios::in | std::ios::out | std::ios::binary | std::ios::trunc);
  ::close(fd);
  ::unlink(name.c_str());
  if (!spool) throw StorageError(name, EIO);
  return spool;
}

}  // namespace

v1::JobStatus toProto(const JobInfo& info) {
  v1::JobStatus s;
  s.set_job_id(info.id);
  s.set_state(toProto(info.state));
  s.set_priority(info.priority);
  s.set_scene_name(info.sceneName);
  s.set_width(uint32_t(info.width));
  s.set_height(uint32_t(info.height));
  s.set_error(info.error);
  s.set_scene_hash(info.sceneHash);
  s.set_submitted_unix_seconds(info.submittedUnixSeconds);
  s.set_version(info.version);
  for (const auto& e : info.effects) s.add_effects(e);
  s.set_kernel(info.kernel);
  for (const auto& b : info.builds) s.add_builds(b);
  auto* p = s.mutable_progress();
  p->set_samples_per_pixel_done(info.samplesPerPixelDone);
  p->set_samples_per_pixel_total(info.samplesPerPixelTotal);
  p->set_units_done(info.unitsDone);
  p->set_units_total(info.unitsTotal);
  p->set_paths(info.stats.paths);
  p->set_rays(info.stats.rays);
  p->set_rays_per_second(info.raysPerSecond());
  p->set_elapsed_seconds(info.elapsedSeconds);
  p->set_remaining_seconds(info.remainingSeconds);
  p->set_workers_busy(info.workersBusy);
  p->set_light_hit_fraction(info.lightHitFraction());
  p->set_dropped_samples(info.stats.dropped);
  p->set_estimated_relative_error(info.estimatedRelativeError);
  p->set_target_error(info.targetError);
  p->set_seconds_to_target(info.secondsToTarget);
  p->set_time_limit_seconds(info.timeLimitSeconds);
  p->set_stop_reason(info.stopReason);
  p->set_stalled_reason(info.stalledReason);
  p->set_progress_fraction(info.progressFraction);
  s.set_audits_passed(info.auditsPassed);
  s.set_audits_failed(info.auditsFailed);
  s.set_audits_explained(info.auditsExplained);
  s.set_audits_pending(info.auditsPending);
  s.set_units_rerendered(info.unitsRerendered);
  for (const JobInfo::Event& e : info.events) {
    v1::JobEvent* event = s.add_events();
    event->set_unix_seconds(e.unixSeconds);
    event->set_text(e.text);
  }
  s.set_tile_size(uint32_t(std::max(0, info.tileSize)));
  s.set_tiles_per_frame(info.tilesPerFrame);
  for (const JobInfo::Frame& f : info.frames) {
    v1::FrameStatus* frame = s.add_frames();
    frame->set_frame(f.number);
    frame->set_tiles_done(f.tilesDone);
    frame->set_tiles_total(f.tilesTotal);
    frame->set_complete(f.complete());
  }
  s.set_owner(info.owner);
  s.set_ended_unix_seconds(info.endedUnixSeconds);
  s.set_archived(info.archived);
  *s.mutable_policy() = proto::toProto(info.policy);
  s.set_paused(info.paused);
  s.set_approved(info.approved);
  for (const std::string& w : info.waitingFor) s.add_waiting_for(w);
  s.set_deadline_outlook(info.deadlineOutlook);
  s.set_prefetch(info.prefetch);
  return s;
}

v1::WorkerStatus toProto(const WorkerView& w) {
  v1::WorkerStatus p;
  p.set_worker_id(w.id);
  p.set_name(w.info.name);
  p.set_threads(w.info.threads);
  p.set_current_job_id(w.currentJobId);
  p.set_units_done(w.unitsDone);
  p.set_seconds_since_heartbeat(w.secondsSinceHeartbeat);
  p.set_renderer_version(w.info.rendererVersion);
  for (const std::string& k : w.info.kernels) p.add_kernels(k);
  for (const std::string& t : w.info.tags) p.add_tags(t);
  p.set_build(w.info.build);
  p.set_cpu(w.info.cpu);
  p.set_state(workerStateName(w.state));
  p.set_seconds_in_state(w.secondsInState);
  p.set_state_reason(w.stateReason);
  p.set_attached(w.attached);
  p.set_failures(w.failures);
  for (const std::string& job : w.blocklistedJobs) p.add_blocklisted_jobs(job);
  p.set_audits_passed(w.auditsPassed);
  p.set_audits_rendered(w.auditsRendered);
  p.set_credential(w.info.credential);
  p.set_registrations(w.registrations);
  p.set_quarantined(w.quarantined);
  p.set_quarantine_reason(w.quarantineReason);
  return p;
}

// ---- ClientService --------------------------------------------------------------------------

grpc::Status ClientServiceImpl::FindMissingAssets(grpc::ServerContext* context,
                                                  const v1::FindMissingAssetsRequest* request,
                                                  v1::FindMissingAssetsResponse* response) {
  return guarded(gate_, context, "FindMissingAssets", [&] {
    const std::vector<std::string> asked(request->sha256().begin(), request->sha256().end());
    for (std::string& sha : coordinator_.missingAssets(asked)) response->add_missing_sha256(std::move(sha));
  });
}

grpc::Status ClientServiceImpl::UploadAsset(grpc::ServerContext* context,
                                            grpc::ServerReader<v1::UploadAssetRequest>* reader,
                                            v1::UploadAssetResponse* response) {
  return guarded(gate_, context, "UploadAsset", [&] {
    v1::UploadAssetRequest message;
    AssetUploadAssembler upload;  // refuses a malformed stream before anything is stored
    MemoryBudget::Reservation held;
    while (reader->Read(&message)) {
      const bool first = !upload.started();
      upload.add(message);
      // Already stored: answer now and read no more (the client's next writes fail; its call ends OK).
      if (first && coordinator_.uploadFindsAssetPresent(upload.sha256())) {
        response->set_sha256(upload.sha256());
        response->set_already_present(true);
        return;
      }
      // Its room, on disk and in memory, before its bytes are read.
      if (first) held = coordinator_.admitAssetUpload(upload.sha256(), upload.declared());
    }
    std::string bytes = upload.finish();
    held.release();  // putAsset reserves what it keeps in memory
    response->set_sha256(upload.sha256());
    response->set_already_present(!coordinator_.putAsset(upload.sha256(), std::move(bytes)));
  });
}

grpc::Status ClientServiceImpl::SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request,
                                          v1::SubmitJobResponse* response) {
  return guarded(gate_, context, "SubmitJob", [&] {
    // A user's job is theirs, whatever the request says (users.h).
    const std::optional<User> user = gate_.userOf(context);
    const JobInfo info = coordinator_.submit(proto::fromProto(request->spec()), request->priority(),
                                             user ? user->name : request->owner(), proto::fromProto(request->policy()),
                                             request->paused());
    response->set_job_id(info.id);
    *response->mutable_status() = toProto(info);
  });
}

grpc::Status ClientServiceImpl::GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                       v1::JobStatus* response) {
  return guarded(gate_, context, "GetJob", [&] { *response = toProto(coordinator_.job(request->job_id())); });
}

Coordinator::JobFilter jobFilterOf(const v1::ListJobsRequest& request) {
  Coordinator::JobFilter filter;
  const JobState all[] = {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kCancelled,
                          JobState::kFailed};
  for (const int state : request.states()) {
    bool known = false;
    for (const JobState s : all)
      if (toProto(s) == state) filter.states.insert(s), known = true;
    if (!known)
      throw FarmError(FarmError::Kind::kInvalidArgument, "states: unknown job state " + std::to_string(state));
  }
  for (const std::string& name : request.state_names()) {
    bool known = false;
    for (const JobState s : all)
      if (name == jobStateName(s)) filter.states.insert(s), known = true;
    if (!known)
      throw FarmError(FarmError::Kind::kInvalidArgument,
                      "state_names: unknown job state \"" + name + "\" (queued, running, done, cancelled, failed)");
  }
  filter.owner = request.owner();
  filter.nameContains = request.name_contains();
  filter.limit = request.limit();
  return filter;
}

grpc::Status ClientServiceImpl::ListJobs(grpc::ServerContext* context, const v1::ListJobsRequest* request,
                                         v1::ListJobsResponse* response) {
  return guarded(gate_, context, "ListJobs", [&] {
    for (const JobInfo& info : coordinator_.jobs(jobFilterOf(*request))) *response->add_jobs() = toProto(info);
  });
}

grpc::Status ClientServiceImpl::DeleteJob(grpc::ServerContext* context, const v1::DeleteJobRequest* request,
                                          v1::DeleteJobResponse*) {
  return guarded(gate_, context, "DeleteJob", [&] {
    checkMayAct(context, "DeleteJob", request->job_id());
    coordinator_.deleteJob(request->job_id(), request->force());
  });
}

grpc::Status ClientServiceImpl::ArchiveJob(grpc::ServerContext* context, const v1::ArchiveJobRequest* request,
                                           v1::ArchiveJobResponse* response) {
  return guarded(gate_, context, "ArchiveJob", [&] {
    checkMayAct(context, "ArchiveJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.archiveJob(request->job_id()));
  });
}

grpc::ServerWriteReactor<v1::JobStatus>* ClientServiceImpl::WatchJob(grpc::CallbackServerContext* context,
                                                                     const v1::WatchJobRequest* request) {
  const grpc::Status admitted = gate_.check(context, "WatchJob");
  return watchers_.watch(request->job_id(), admitted.ok() ? gate_.roleOf(context) : "", admitted);
}

grpc::Status ClientServiceImpl::Download(grpc::ServerContext* context, const v1::DownloadRequest* request,
                                         grpc::ServerWriter<v1::FileChunk>* writer) {
  return guarded(gate_, context, "Download", [&] {
    if (request->format() != v1::IMAGE_FORMAT_PNG && request->format() != v1::IMAGE_FORMAT_EXR)
      throw FarmError(FarmError::Kind::kInvalidArgument, "Download: format must be EXR or PNG");
    const bool exr = request->format() == v1::IMAGE_FORMAT_EXR;
    const std::string role = gate_.roleOf(context);
    const std::optional<RoleSlots::Slot> slot = downloads_.take(role);
    if (!slot)
      throw FarmError(FarmError::Kind::kResourceExhausted,
                      "Download: " + std::to_string(downloads_.perRole()) + " downloads of the " + role +
                          " role are in progress, the most at once; try again when one ends");
    // An archived still's EXR is streamed as stored: no image developed, nothing frame-sized held.
    uint64_t size = 0;
    if (exr && !request->has_frame())
      if (std::unique_ptr<std::istream> stored = coordinator_.archivedExr(request->job_id(), &size)) {
        writeChunks(writer, *stored, size);
        return;
      }
    // Otherwise the image, its memory reserved from the coordinator's budget while it lives.
    JobImage image = coordinator_.image(request->job_id(),
                                        request->has_frame() ? std::optional<int64_t>(request->frame()) : std::nullopt);
    if (!exr) {
      if (request->has_ev()) image.exposure.ev = checkedEv(request->ev());
      writeChunks(writer, encodePng(image.image, image.exposure));
    } else if (image.image.rgb.size() * sizeof(float) <= kSpoolAboveBytes) {
      writeChunks(writer, encodeExr(image.image, image.metadata));
    } else {
      std::fstream spool = openSpool(coordinator_.spoolDirectory());
      try {
        writeExr(spool, image.image, image.metadata);
      } catch (const std::exception&) {
        throw StorageError(coordinator_.spoolDirectory() / ".download-*", errno ? errno : EIO);
      }
      size = uint64_t(spool.tellp());
      image = JobImage();  // the image goes before the bytes are streamed
      spool.seekg(0);
      writeChunks(writer, spool, size);
    }
  });
}

grpc::Status ClientServiceImpl::GetSnapshot(grpc::ServerContext* context, const v1::SnapshotRequest* request,
                                            v1::Snapshot* response) {
  return guarded(gate_, context, "GetSnapshot", [&] {
    constexpr uint32_t kDefaultSize = 512, kLargest = 1024;  // a 1024^2 PNG stays far below 4 MiB
    const uint32_t maxSize = std::min(request->max_size() ? request->max_size() : kDefaultSize, kLargest);
    *response->mutable_status() = toProto(coordinator_.job(request->job_id()));
    JobImage image = coordinator_.image(request->job_id(),
                                        request->has_frame() ? std::optional<int64_t>(request->frame()) : std::nullopt);
    if (request->has_ev()) image.exposure.ev = checkedEv(request->ev());
    // A box filter keeps the mean luminance, so the automatic exposure matches the download's.
    const Image preview = downscaleToFit(image.image, int(maxSize));
    response->set_png(encodePng(preview, image.exposure));
    response->set_width(uint32_t(preview.width));
    response->set_height(uint32_t(preview.height));
  });
}

grpc::Status ClientServiceImpl::CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                                          v1::CancelJobResponse* response) {
  return guarded(gate_, context, "CancelJob", [&] {
    checkMayAct(context, "CancelJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.cancel(request->job_id()));
  });
}

void ClientServiceImpl::checkMayAct(const grpc::ServerContextBase* context, const std::string& action,
                                    const std::string& jobId) const {
  const std::optional<User> user = gate_.userOf(context);
  if (!user) return;
  lensfarm::checkMayAct(*user, action, jobId, coordinator_.job(jobId).owner);
}

grpc::Status ClientServiceImpl::PauseJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                                         v1::JobActionResponse* response) {
  return guarded(gate_, context, "PauseJob", [&] {
    checkMayAct(context, "PauseJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.pauseJob(request->job_id()));
  });
}

grpc::Status ClientServiceImpl::ResumeJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                                          v1::JobActionResponse* response) {
  return guarded(gate_, context, "ResumeJob", [&] {
    checkMayAct(context, "ResumeJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.resumeJob(request->job_id()));
  });
}

grpc::Status ClientServiceImpl::ApproveJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                                           v1::JobActionResponse* response) {
  return guarded(gate_, context, "ApproveJob", [&] {
    checkMayAct(context, "ApproveJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.approveJob(request->job_id()));
  });
}

grpc::Status ClientServiceImpl::UpdateJob(grpc::ServerContext* context, const v1::UpdateJobRequest* request,
                                          v1::JobActionResponse* response) {
  return guarded(gate_, context, "UpdateJob", [&] {
    checkMayAct(context, "UpdateJob", request->job_id());
    Coordinator::JobUpdate update;
    if (request->has_priority()) update.priority = request->priority();
    if (request->has_max_workers()) update.maxWorkers = request->max_workers();
    if (request->has_share_weight()) update.shareWeight = request->share_weight();
    *response->mutable_status() = toProto(coordinator_.updateJob(request->job_id(), update));
  });
}

grpc::Status ClientServiceImpl::PrefetchJob(grpc::ServerContext* context, const v1::JobActionRequest* request,
                                            v1::JobActionResponse* response) {
  return guarded(gate_, context, "PrefetchJob", [&] {
    checkMayAct(context, "PrefetchJob", request->job_id());
    *response->mutable_status() = toProto(coordinator_.prefetchJob(request->job_id()));
  });
}

grpc::Status ClientServiceImpl::ListEvents(grpc::ServerContext* context, const v1::ListEventsRequest* request,
                                           v1::ListEventsResponse* response) {
  return guarded(gate_, context, "ListEvents", [&] {
    constexpr uint32_t kMost = 1000;
    if (!(request->wait_seconds() >= 0 && request->wait_seconds() <= 30))
      throw InputError("wait_seconds", "expected seconds in [0, 30]");
    const size_t limit = request->limit() == 0 || request->limit() > kMost ? kMost : request->limit();
    const EventFeed& feed = coordinator_.events();
    // Filtered by job, a long poll waits for an event of that job (in slices, so a busy farm's
    // other events do not end it early).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(request->wait_seconds());
    uint64_t cursor = request->after();
    for (;;) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      const std::vector<FarmEvent> events = feed.after(cursor, kMost, std::max(left, std::chrono::milliseconds(0)));
      for (const FarmEvent& e : events) {
        cursor = e.sequence;
        if (!request->job_id().empty() && e.jobId != request->job_id()) continue;
        *response->add_events() = proto::toProto(e);
        if (size_t(response->events_size()) == limit) break;
      }
      if (response->events_size() > 0 || events.empty() || context->IsCancelled() ||
          std::chrono::steady_clock::now() >= deadline)
        break;
    }
    response->set_latest(feed.latest());
    response->set_oldest(feed.oldest());
  });
}

grpc::Status ClientServiceImpl::ListWorkers(grpc::ServerContext* context, const v1::ListWorkersRequest*,
                                            v1::ListWorkersResponse* response) {
  return guarded(gate_, context, "ListWorkers", [&] {
    for (const WorkerView& w : coordinator_.workers()) *response->add_workers() = toProto(w);
  });
}

grpc::Status ClientServiceImpl::GetServerInfo(grpc::ServerContext* context, const v1::GetServerInfoRequest*,
                                              v1::ServerInfo* response) {
  return guarded(gate_, context, "GetServerInfo", [&] {
    response->set_renderer_version(kRendererVersion);
    response->set_api(v1::ServerInfo::descriptor()->file()->package());
    const std::string role = gate_.roleOf(context);
    const std::optional<User> user = gate_.userOf(context);
    response->set_identity(user ? user->name : role);
    response->set_role(role);
  });
}

// ---- WorkerService --------------------------------------------------------------------------

grpc::Status WorkerServiceImpl::Register(grpc::ServerContext* context, const v1::RegisterRequest* request,
                                         v1::RegisterResponse* response) {
  return guarded(gate_, context, "Register", [&] {
    if (request->name().size() > kMaxWorkerNameBytes)
      throw InputError("name", "at most " + std::to_string(kMaxWorkerNameBytes) + " bytes");
    // What a worker says of itself is shown to people and written into EXR headers: short and printable.
    const auto checkText = [](const char* field, const std::string& text, size_t most) {
      if (text.size() > most) throw InputError(field, "at most " + std::to_string(most) + " bytes");
      for (unsigned char c : text)
        if (c < 0x20 || c == 0x7f) throw InputError(field, "holds a control character");
    };
    if (request->kernels_size() > 16) throw InputError("kernels", "at most 16 names");
    for (const std::string& k : request->kernels()) checkText("kernels", k, 32);
    checkText("build", request->build(), 256);
    checkText("cpu", request->cpu(), 256);
    if (request->tags_size() > int(kMaxTags))
      throw FarmError(FarmError::Kind::kInvalidArgument, "tags: at most " + std::to_string(kMaxTags));
    for (int i = 0; i < request->tags_size(); ++i) checkTag(request->tags(i), "tags[" + std::to_string(i) + "]");
    WorkerInfo info{request->name(),
                    std::max(1u, request->threads()),
                    request->protocol_version(),
                    request->renderer_version(),
                    request->max_unit_memory_bytes(),
                    gate_.credentialOf(context),
                    {request->kernels().begin(), request->kernels().end()},
                    request->build(),
                    request->cpu(),
                    {request->tags().begin(), request->tags().end()}};
    std::string session;
    response->set_worker_id(coordinator_.registerWorker(info, &session));
    response->set_session(session);
    response->set_heartbeat_interval_ms(uint32_t(coordinator_.options().heartbeatIntervalSeconds * 1000));
  });
}

grpc::Status WorkerServiceImpl::Heartbeat(grpc::ServerContext* context, const v1::HeartbeatRequest* request,
                                          v1::HeartbeatResponse* response) {
  return guarded(gate_, context, "Heartbeat", [&] {
    coordinator_.authenticateWorker(request->worker_id(), request->session());
    const std::vector<uint64_t> leases(request->lease_ids().begin(), request->lease_ids().end());
    for (uint64_t id : coordinator_.heartbeat(request->worker_id(), leases)) response->add_revoked_lease_ids(id);
  });
}

grpc::Status WorkerServiceImpl::LeaseWork(grpc::ServerContext* context, const v1::LeaseWorkRequest* request,
                                          v1::LeaseWorkResponse* response) {
  return guarded(gate_, context, "LeaseWork", [&] {
    coordinator_.authenticateWorker(request->worker_id(), request->session());
    const double wait = std::min(10.0, request->wait_ms() / 1000.0);
    if (auto grant = coordinator_.lease(request->worker_id(), wait)) {
      grant->uploadEncoding = uploadEncoding_;
      *response->mutable_lease() = proto::toProto(*grant);
    } else {
      response->set_prefetch_job_id(coordinator_.takePrefetch(request->worker_id()));
    }
  });
}

grpc::Status WorkerServiceImpl::GetJobSpec(grpc::ServerContext* context, const v1::GetJobSpecRequest* request,
                                           v1::JobSpec* response) {
  return guarded(gate_, context, "GetJobSpec", [&] {
    coordinator_.authenticateWorker(request->worker_id(), request->session());
    *response = proto::toProto(coordinator_.jobSpecFor(request->worker_id(), request->job_id()));
  });
}

grpc::Status WorkerServiceImpl::FetchAsset(grpc::ServerContext* context, const v1::FetchAssetRequest* request,
                                           grpc::ServerWriter<v1::FileChunk>* writer) {
  return guarded(gate_, context, "FetchAsset", [&] {
    coordinator_.authenticateWorker(request->worker_id(), request->session());
    writeChunks(writer, *coordinator_.assetFor(request->worker_id(), request->sha256()));
  });
}

grpc::Status WorkerServiceImpl::UploadResult(grpc::ServerContext* context,
                                             grpc::ServerReader<v1::UploadResultRequest>* reader,
                                             v1::UploadResultResponse* response) {
  return guarded(gate_, context, "UploadResult", [&] {
    v1::UploadResultRequest message;
    UploadAssembler assembler;
    bool first = true;
    while (reader->Read(&message)) {
      if (first) {  // who sends it, and for what, before any sum is read
        const UploadHeader& h = assembler.begin(message);
        coordinator_.authenticateWorker(h.workerId, h.session);
        coordinator_.admitUpload(h.workerId, h.leaseId, h.jobId, h.unitIndex, int(std::min(h.width, 1u << 20)),
                                 int(std::min(h.height, 1u << 20)), int(std::min(h.channels, 1u << 20)));
      }
      first = false;
      assembler.add(message);
    }
    UnitResult result = assembler.finish();
    coordinator_.countUnitWireBytes(assembler.wireBytes());
    response->set_accepted(coordinator_.acceptResult(std::move(result)));
  });
}

// One worker's Attach stream: the worker names itself, gets one event back, and holds the stream
// for its life. How it ends says how the worker went: a `leaving` message first makes it left;
// any other end (its connection closed, keepalive pings unanswered, the call cancelled) makes it
// lost at once (Coordinator::workerLost). gRPC may run OnCancel beside OnReadDone, so the state
// they share is atomic, and Finish is called once.
class AttachReactor final : public grpc::ServerBidiReactor<v1::AttachRequest, v1::AttachEvent> {
 public:
  AttachReactor(WorkerServiceImpl& service, grpc::CallbackServerContext* context) : service_(service) {
    {
      std::lock_guard lock(service_.attachMutex_);
      service_.attached_.insert(this);
      if (service_.closing_) {
        finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "Attach: coordinator shutting down"));
        return;
      }
    }
    if (grpc::Status s = service_.gate_.check(context, "Attach"); !s.ok()) {
      finish(s);
      return;
    }
    read();
  }

  void OnReadDone(bool ok) override {
    if (!ok) {  // half-closed without leaving, or the connection broke
      ended();
      return;
    }
    if (attachment_.load() == 0 && workerId_.empty()) {
      workerId_ = request_.worker_id();
      try {
        service_.coordinator_.authenticateWorker(workerId_, request_.session());
        attachment_.store(service_.coordinator_.attachWorker(workerId_));
      } catch (const FarmError& e) {
        finish(farmStatus(e));
        return;
      } catch (const std::exception& e) {
        finish(grpc::Status(grpc::StatusCode::INTERNAL, std::string("Attach: ") + e.what()));
        return;
      }
      if (finished_) {  // the call ended while it attached (OnCancel saw no attachment yet)
        if (!closing_) service_.coordinator_.workerLost(workerId_, "connection broke", attachment_.load());
        return;
      }
      event_.set_attached(true);
      std::lock_guard lock(ops_);
      if (!finished_) StartWrite(&event_);
    } else if (request_.leaving()) {
      leaving_ = true;
      service_.coordinator_.workerLeft(workerId_, attachment_.load());
      finish(grpc::Status::OK);
      return;
    }
    read();
  }
  void OnWriteDone(bool) override {}
  void OnCancel() override { ended(); }
  void OnDone() override {
    {
      std::lock_guard lock(service_.attachMutex_);
      service_.attached_.erase(this);
    }
    delete this;
  }

  // The coordinator is shutting down: end the stream without calling the worker lost.
  void close() {
    closing_ = true;
    finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "Attach: coordinator shutting down"));
  }

 private:
  void ended() {
    const uint64_t attachment = attachment_.load();
    if (attachment != 0 && !leaving_ && !closing_)
      service_.coordinator_.workerLost(workerId_, "connection broke", attachment);
    finish(grpc::Status(grpc::StatusCode::CANCELLED, "Attach: stream ended"));
  }
  // No operation may start after Finish (close() may finish from another thread).
  void read() {
    std::lock_guard lock(ops_);
    if (!finished_) StartRead(&request_);
  }
  void finish(const grpc::Status& status) {
    std::lock_guard lock(ops_);
    if (!finished_.exchange(true)) Finish(status);
  }

  WorkerServiceImpl& service_;
  v1::AttachRequest request_;
  v1::AttachEvent event_;
  std::string workerId_;  // written before attachment_ is set, read after it is seen set
  std::atomic<uint64_t> attachment_{0};
  std::atomic<bool> leaving_{false}, closing_{false}, finished_{false};
  std::mutex ops_;
};

grpc::ServerBidiReactor<v1::AttachRequest, v1::AttachEvent>* WorkerServiceImpl::Attach(
    grpc::CallbackServerContext* context) {
  return new AttachReactor(*this, context);
}

void WorkerServiceImpl::endAttachments() {
  std::lock_guard lock(attachMutex_);
  closing_ = true;
  const std::set<AttachReactor*> open = attached_;  // a reactor leaves attached_ only under the lock
  for (AttachReactor* r : open) r->close();
}

WorkerServiceImpl::~WorkerServiceImpl() = default;

grpc::Status WorkerServiceImpl::ReportFailure(grpc::ServerContext* context, const v1::ReportFailureRequest* request,
                                              v1::ReportFailureResponse*) {
  return guarded(gate_, context, "ReportFailure", [&] {
    coordinator_.authenticateWorker(request->worker_id(), request->session());
    // The worker's words are kept for the job's error and events, at most kMaxFailureTextBytes.
    const std::string& error = request->error();
    coordinator_.reportFailure(
        request->worker_id(), request->lease_id(), request->job_id(),
        error.size() <= kMaxFailureTextBytes ? error : error.substr(0, kMaxFailureTextBytes) + "...");
  });
}

}  // namespace lensfarm
