// Coordinator, the job table: construction, submission (validated against the assets and the
// memory budget), each job's state and how it ends (cancel, finish), what clients read (JobInfo,
// the image, the error curve, metrics), and the asset calls, forwarded to AssetStore. Leases are
// in scheduler.cpp, results in results.cpp, durable state in persistence.cpp, workers in
// workers.cpp; the records they share are in coordinator_records.h.
#include "coordinator/core/coordinator.h"
#include "common/scene/scene_diffraction.h"
#include "common/util/log_text.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <random>

#include "common/farm/job_scene.h"
#include "common/farm/memory_estimate.h"
#include "common/film/psf_convolution.h"
#include "common/scene/asset_path.h"
#include "common/scene/effects.h"
#include "common/scene/scene_camera.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/store/frame_store.h"
#include "coordinator/store/job_archive.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

namespace {
std::vector<std::string> describeEffects(const Scene& scene) {
  std::vector<std::string> out;
  // The declared camera: a real lens says what share of rays it lets through.
  for (const auto& d : analyzeEffects(scene, *declaredCamera(scene)).decisions)
    out.push_back(d.effect + ": " + (d.simulated ? "on" : "off") + " (" + d.reason + ")");
  return out;
}

// Checks the spec's assets before anything is loaded: each hash well formed, each name a path
// (never a URL), and each uploaded to `assets`.
void checkSpecAssets(const JobSpec& spec, const AssetStore& assets) {
  // Hashes as every call takes them (AssetStore::checkSha256): a badly written one is an error
  // of its own, not an asset that was never uploaded.
  for (const auto& [path, sha] : spec.assets) AssetStore::checkSha256(sha, "assets[" + path + "].sha256");
  // Asset names are the paths the client's loader read (scene/asset_path.h): never a URL. They
  // are keys of uploaded files only: nothing on the coordinator's (or a worker's) disk is read
  // by them.
  for (const auto& [path, sha] : spec.assets)
    if (const std::optional<std::string> problem = unreadablePathProblem(path))
      throw FarmError(FarmError::Kind::kInvalidArgument, "assets[\"" + path + "\"]: " + *problem);
  std::string missing;
  for (const auto& [path, sha] : spec.assets)
    if (!assets.has(sha)) missing += (missing.empty() ? "" : ", ") + path + " (" + sha.substr(0, 12) + ")";
  if (!missing.empty()) throw FarmError(FarmError::Kind::kFailedPrecondition, "assets not uploaded: " + missing);
}

// Checks a job's frame range: a step of at least 1, last not before first, at most
// kMaxFramesInRange frames.
void checkFrameRange(const FrameRange& f) {
  if (f.step < 1)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "frames.step: must be at least 1, got " + std::to_string(f.step));
  if (f.last < f.first)
    throw FarmError(FarmError::Kind::kInvalidArgument, "frames: the last frame " + std::to_string(f.last) +
                                                           " is before the first " + std::to_string(f.first));
  if (f.count() > kMaxFramesInRange)
    throw FarmError(FarmError::Kind::kInvalidArgument, "frames: " + std::to_string(f.count()) + " frames; at most " +
                                                           std::to_string(kMaxFramesInRange) + " a job");
}

// Checks that every asset the loaded scene read is listed, with the same hash, in the spec.
void checkSceneAssetsListed(const Scene& scene, const JobSpec& spec) {
  for (const auto& [path, sha] : scene.assets)
    if (!spec.assets.count(path) || spec.assets.at(path) != sha)
      throw FarmError(FarmError::Kind::kInvalidArgument, "asset " + path + " is not listed in the job spec");
}
}  // namespace

const char* jobStateName(JobState s) {
  switch (s) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kDone: return "done";
    case JobState::kCancelled: return "cancelled";
    case JobState::kFailed: return "failed";
  }
  return "?";
}

Coordinator::Coordinator(Options options) : options_(std::move(options)), auditRandom_(std::random_device{}()) {
  if (options_.maxJobMemoryBytes == 0) {
    options_.maxJobMemoryBytes = defaultJobMemoryBudget();
    options_.maxJobMemorySource = defaultJobMemoryBudgetSource();
  }
  if (options_.memoryBudgetBytes == 0) {
    options_.memoryBudgetBytes = defaultJobMemoryBudget();
    options_.memoryBudgetSource = defaultJobMemoryBudgetSource();
  }
  memory_ = MemoryBudget::create(options_.memoryBudgetBytes);
  assets_.setQuota(options_.maxAssetBytes);
  frames_ = std::make_unique<FrameStore>(options_.stateDir);
  archive_ = std::make_unique<JobArchive>(options_.stateDir);
  if (options_.stateDir.empty()) {
    epoch_ = std::random_device{}() & 0xfffff;
    setWorkerEpoch();
  } else {
    store_ = std::make_unique<StateStore>(options_.stateDir);
    epoch_ = store_->bootCount();
    setWorkerEpoch();
    restore();
    // The events go on from where they were, each kept as it is published (a write that fails
    // is logged: an event is worth less than the job it is about).
    events_.restore(store_->loadEvents());
    events_.setSink([this](const FarmEvent& e) {
      try {
        store_->appendEvent(e, events_.capacity());
      } catch (const std::exception& error) {
        spdlog::warn("event {} ({}) not kept in the state dir: {}", e.sequence, e.type, error.what());
      }
    });
    checkpointer_ = std::thread([this] { checkpointLoop(); });
  }
  startLifecycle();
}

Coordinator::Coordinator() : Coordinator(Options{}) {}

Coordinator::~Coordinator() {
  stopLifecycle();
  if (!store_) return;
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  checkpointWake_.notify_all();
  checkpointer_.join();
  try {
    checkpoint();
  } catch (const std::exception& e) {
    spdlog::error("final checkpoint failed: {}", e.what());
  }
}

void JobDefinition::setScene(const Scene& scene) {
  settings = scene.render;
  sceneHash = scene.hash;
  unitSize = lensfarm::unitSize(scene.render);
  layout = JobLayout::of(scene.render, spec.frames);
  effects = describeEffects(scene);
  diffraction = diffractionKernelFor(scene);
  unitMemoryBytes = workerJobMemory(scene.render, storedTriangles(scene), sceneDataBytes(scene)).total();
}

// ---- assets (AssetStore) --------------------------------------------------------------------

bool Coordinator::hasAsset(const std::string& sha256) const { return assets_.has(sha256); }

bool Coordinator::putAsset(const std::string& sha256, std::string bytes) {
  if (store_) return assets_.put(sha256, std::move(bytes));  // on disk, read while in use
  // In memory for the coordinator's life: a share of its budget.
  const uint64_t size = bytes.size();
  std::optional<MemoryBudget::Reservation> reserved = memory_->tryReserve(size, "asset " + sha256.substr(0, 12));
  if (!reserved)
    throw FarmError(FarmError::Kind::kResourceExhausted, "asset " + sha256.substr(0, 12) + " (" + formatBytes(size) +
                                                             ") does not fit in the coordinator's memory (" +
                                                             memoryBudgetText() +
                                                             "); run it with --state-dir to keep assets on disk");
  if (!assets_.put(sha256, std::move(bytes))) return false;  // present already: the reservation goes back
  MutexLock lock(mutex_);
  assetMemory_.emplace(sha256, std::move(*reserved));
  return true;
}

std::string Coordinator::memoryBudgetText() const { return memory_->describe() + ", " + options_.memoryBudgetSource; }

bool Coordinator::uploadFindsAssetPresent(const std::string& sha256) { return assets_.uploadFindsPresent(sha256); }

MemoryBudget::Reservation Coordinator::admitAssetUpload(const std::string& sha256, uint64_t bytes) {
  assets_.checkRoom(sha256, bytes);
  const std::string what = "uploading asset " + sha256.substr(0, 12);
  std::optional<MemoryBudget::Reservation> reserved =
      memory_->reserve(bytes, what, std::chrono::milliseconds(int64_t(options_.imageWaitSeconds * 1000.0)));
  if (!reserved)
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    what + " (" + formatBytes(bytes) +
                        ") needs as much coordinator memory while it arrives, and the "
                        "coordinator " +
                        memoryBudgetText() + "; try again when other uploads have ended");
  return std::move(*reserved);
}

std::vector<std::string> Coordinator::missingAssets(const std::vector<std::string>& sha256s) const {
  return assets_.missing(sha256s);
}

std::shared_ptr<const std::string> Coordinator::asset(const std::string& sha256) { return assets_.send(sha256); }

// ---- jobs -----------------------------------------------------------------------------------

JobInfo Coordinator::submit(const JobSpec& spec, int priority, const std::string& owner, const JobPolicy& policy,
                            bool paused) {
  checkPolicy(policy);
  checkSpecAssets(spec, assets_);
  // Load the scene exactly as a worker will, to validate it and fix its settings and hash.
  const AssetReader reader = [&](const std::string& path) -> std::optional<std::string> {
    auto it = spec.assets.find(path);
    if (it == spec.assets.end()) return std::nullopt;
    return *assets_.get(it->second);
  };
  JobSpec resolved = spec;
  if (spec.frames) checkFrameRange(*spec.frames);
  Scene scene = jobScene(spec, reader);
  {
    // The layout is fixed now, in the spec every process reads: the same units after a restart.
    uint32_t live = 0;
    {
      MutexLock lock(mutex_);
      for (const auto& [id, w] : workers_) live += !w->gone;
    }
    resolved.overrides.tileSize = resolveTileSize(scene.render, spec.frames, live);
    scene.render.tileSize = *resolved.overrides.tileSize;
  }
  checkSceneAssetsListed(scene, spec);

  // Refuse what this coordinator cannot hold before allocating anything frame-sized.
  const MemoryEstimate memory = coordinatorJobMemory(scene.render, options_.maxBytesAhead, store_ != nullptr,
                                                     options_.auditFraction > 0.0 ? kRewindPoints : 0);
  if (memory.total() > options_.maxJobMemoryBytes)
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    spec.sceneName + ": " +
                        overBudgetMessage(scene.render, memory, "coordinator", options_.maxJobMemoryBytes,
                                          options_.maxJobMemorySource) +
                        "; lower the resolution (--resolution) or give the coordinator more (--max-job-memory)");

  if (options_.maxJobsPerOwner > 0) {
    MutexLock lock(mutex_);
    uint32_t unfinished = 0;
    for (const auto& [id, j] : jobs_) unfinished += j->definition.owner == owner && !isTerminal(j->progress.state);
    if (unfinished >= options_.maxJobsPerOwner)
      throw FarmError(FarmError::Kind::kResourceExhausted,
                      spec.sceneName + ": " +
                          (owner.empty() ? std::string("the unnamed owner") : "owner " + logText(owner)) + " has " +
                          std::to_string(unfinished) + " jobs queued or running, the most allowed (" +
                          "--max-jobs-per-owner); wait for some to end or cancel them");
  }
  // Its film's share of the coordinator's whole budget, beside every other job's (one image, the
  // last item, is reserved by each download or archiving when it happens).
  const uint64_t filmBytes = memory.total() - memory.items.back().bytes;
  std::optional<MemoryBudget::Reservation> reserved = memory_->tryReserve(filmBytes, spec.sceneName);
  if (!reserved)
    throw FarmError(
        FarmError::Kind::kResourceExhausted,
        spec.sceneName + ": the job needs " + formatBytes(filmBytes) + " of coordinator memory (" + memory.describe() +
            ", less a download reserved when it happens), and the coordinator " + memoryBudgetText() +
            "; wait for jobs to end, delete or archive ended ones (lensfarm delete), or raise --memory-budget");

  auto job = std::make_unique<Job>();
  job->memory = std::move(*reserved);
  job->definition.spec = resolved;
  job->priority = priority;
  job->definition.owner = owner;
  job->definition.policy = policy;
  job->released = policy.after.empty();
  job->paused = paused;
  if (spec.overrides.kernel) job->kernel = kernelName(*spec.overrides.kernel);
  job->setScene(scene);
  try {
    if (options_.beforeJobAllocation) options_.beforeJobAllocation(memory.total());
    job->film = std::make_unique<Accumulator>(scene.render, job->definition.layout);
  } catch (const std::bad_alloc&) {
    // This job is refused; the coordinator and its other jobs go on.
    const std::string what = spec.sceneName + ": out of memory allocating the " + std::to_string(scene.render.width) +
                             "x" + std::to_string(scene.render.height) + " job's sensor (estimated " +
                             formatBytes(memory.total()) + " in all); the job was not queued";
    spdlog::error("SubmitJob: {}", logText(what));
    throw FarmError(FarmError::Kind::kResourceExhausted, what);
  }
  job->definition.submittedUnixSeconds =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();

  MutexLock lock(mutex_);
  checkDependenciesExist(policy);
  // Checked again under the lock: the asset garbage collection removes only under it.
  checkSpecAssets(spec, assets_);
  checkOwnerQuotas(job->definition.owner, spec,
                   uint64_t(job->definition.layout.width) * uint64_t(job->definition.layout.height) *
                       job->definition.layout.samplesPerPixel * job->definition.layout.frameCount());
  job->definition.id = "job-" + std::to_string(nextJob_++);
  job->definition.sequence = nextSequence_++;
  job->memory.rename(job->definition.id);
  if (store_)
    store_->insertJob(StateStore::StoredJob{
        job->definition.id, job->definition.sequence, job->priority, job->definition.spec,
        jobStateName(job->progress.state), "", job->definition.submittedUnixSeconds, 0, std::nullopt, "",
        job->definition.owner, 0.0, false, "", "", policyToJson(policy), paused, false, job->released});
  spdlog::info("job {}: {} {}x{}, {} spp in {} units of {}, priority {}{}", job->definition.id, logText(spec.sceneName),
               job->definition.settings.width, job->definition.settings.height, job->definition.layout.samplesPerPixel,
               job->progress.units.total(), job->definition.unitSize, priority,
               job->definition.layout.adaptive() ? "; " + job->definition.layout.adaptiveSummary() : "");
  Job& ref = *job;
  jobs_[job->definition.id] = std::move(job);
  notify(ref, farm_event::kJobSubmitted,
         ref.definition.spec.sceneName + (paused ? " (paused)" : "") +
             (ref.released ? "" : " (waits for its dependencies)"));
  updateDependencies();  // (those already held release it now; one that cannot hold fails it)
  changed_.notify_all();
  return infoOf(ref);
}

double progressFraction(const JobInfo& info, double nowUnixSeconds) {
  if (info.state == JobState::kDone) return 1.0;
  // Without a cap of its own (only the internal kMaxSamplesPerPixel) units say nothing.
  double fraction = info.samplesPerPixelTotal < kMaxSamplesPerPixel && info.unitsTotal
                        ? double(info.unitsDone) / double(info.unitsTotal)
                        : 0.0;
  // The error's square falls as 1/time: (target / estimate)^2 of the time needed has passed.
  if (info.targetError > 0.0 && info.estimatedRelativeError > 0.0) {
    const double r = info.targetError / info.estimatedRelativeError;
    fraction = std::max(fraction, std::min(1.0, r * r));
  }
  // The deadline counts from submission.
  if (info.timeLimitSeconds > 0.0) {
    const double used = isTerminal(info.state) ? info.elapsedSeconds : nowUnixSeconds - info.submittedUnixSeconds;
    fraction = std::max(fraction, std::clamp(used / info.timeLimitSeconds, 0.0, 1.0));
  }
  return std::clamp(fraction, 0.0, 1.0);
}

Coordinator::Job& Coordinator::findJob(const std::string& jobId) const {
  auto it = jobs_.find(jobId);
  // A deleted job's id is refused like a revoked lease: an upload for it changes nothing.
  if (it == jobs_.end() && deletedJobs_.count(jobId))
    throw FarmError(FarmError::Kind::kFailedPrecondition, jobId + " was deleted");
  if (it == jobs_.end()) throw FarmError(FarmError::Kind::kNotFound, "no job " + jobId);
  return *it->second;
}

double Coordinator::elapsedSecondsOf(const Job& job) {
  if (!job.progress.started) return 0.0;
  return std::chrono::duration<double>(job.progress.finished.value_or(Clock::now()) - *job.progress.started).count();
}

JobInfo Coordinator::infoOf(const Job& job) const {
  JobInfo info;
  info.id = job.definition.id;
  info.state = job.progress.state;
  info.priority = job.priority;
  info.sceneName = job.definition.spec.sceneName;
  info.sceneHash = job.definition.sceneHash;
  info.width = job.definition.settings.width;
  info.height = job.definition.settings.height;
  info.samplesPerPixelDone = job.progress.samplesPerPixelDone;
  info.samplesPerPixelTotal = job.definition.settings.samplesPerPixel;
  info.unitsDone = job.progress.unitsAdded;
  info.unitsTotal = job.progress.units.total();
  info.stats = job.progress.stats;
  if (job.definition.layout.tiled()) {
    info.tileSize = job.definition.layout.tileSize;
    info.tilesPerFrame = job.definition.layout.unitsPerFrame();
  }
  if (job.definition.layout.frames) {
    // One lock for every frame's count; an archived job (no film) has its stored frames whole.
    const std::vector<uint32_t> done = job.film ? job.film->tilesDonePerFrame() : std::vector<uint32_t>{};
    const std::set<uint64_t> stored = job.film ? std::set<uint64_t>{} : frames_->storedFrames(job.definition.id);
    info.frames.resize(job.definition.layout.frameCount());
    for (uint64_t f = 0; f < info.frames.size(); ++f)
      info.frames[f] = JobInfo::Frame{job.definition.layout.frameNumber(f),
                                      f < done.size()   ? done[f]
                                      : stored.count(f) ? info.tilesPerFrame
                                                        : 0,
                                      info.tilesPerFrame};
  }
  info.elapsedSeconds = elapsedSecondsOf(job);
  const double fraction =
      job.progress.units.total() ? double(job.progress.unitsAdded) / double(job.progress.units.total()) : 0.0;
  if (!isTerminal(job.progress.state) && fraction > 0.0)
    info.remainingSeconds = info.elapsedSeconds * (1.0 - fraction) / fraction;
  info.estimatedRelativeError = job.progress.estimate.valid ? job.progress.estimate.relativeRmse : -1.0;
  info.targetError = job.definition.settings.targetError;
  info.timeLimitSeconds = job.definition.settings.timeLimitSeconds;
  info.stopReason = job.progress.stopReason;
  if (!isTerminal(job.progress.state) && job.progress.estimate.valid && info.targetError > 0.0) {
    info.secondsToTarget = secondsToTarget(job.progress.estimate.relativeRmse, info.targetError, info.elapsedSeconds);
    info.remainingSeconds = std::min(info.remainingSeconds, info.secondsToTarget);
  }
  if (!isTerminal(job.progress.state) && info.timeLimitSeconds > 0.0) {
    const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    const double left = std::max(0.0, job.definition.submittedUnixSeconds + info.timeLimitSeconds - nowUnix);
    info.remainingSeconds = info.remainingSeconds > 0.0 ? std::min(info.remainingSeconds, left) : left;
  }
  info.workersBusy = uint32_t(leases_.ofJob(job.definition.id).size());
  info.auditsPassed = job.audit.auditsPassed;
  info.auditsFailed = job.audit.auditsFailed;
  info.auditsExplained = job.audit.auditsExplained;
  info.auditsPending = job.audit.audits.size();
  info.unitsRerendered = job.audit.unitsRerendered;
  info.events = job.events;
  info.error = job.progress.error;
  info.submittedUnixSeconds = job.definition.submittedUnixSeconds;
  info.version = job.progress.version;
  info.effects = job.definition.effects;
  info.kernel = job.kernel;
  for (const auto& [build, units] : job.progress.unitsByBuild)
    info.builds.push_back(build + ": " + std::to_string(units) + " units");
  info.owner = job.definition.owner;
  info.endedUnixSeconds = job.retention.endedUnixSeconds;
  info.archived = job.retention.archived;
  info.policy = job.definition.policy;
  info.paused = job.paused;
  info.approved = job.approved;
  info.prefetch = job.prefetch;
  if (!job.released && !isTerminal(job.progress.state)) info.waitingFor = dependencyWaits(job, nullptr);
  if (!isTerminal(job.progress.state)) info.deadlineOutlook = job.progress.deadlineOutlook;
  info.stalledReason = stalledReason(job, Clock::now());
  info.progressFraction = progressFraction(
      info, std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
  return info;
}

JobInfo Coordinator::job(const std::string& jobId) const {
  MutexLock lock(mutex_);
  if (deletedJobs_.count(jobId)) throw FarmError(FarmError::Kind::kNotFound, "no job " + jobId + " (it was deleted)");
  return infoOf(findJob(jobId));
}

std::vector<JobInfo> Coordinator::jobs() const {
  MutexLock lock(mutex_);
  std::vector<const Job*> ordered;
  for (const auto& [id, job] : jobs_) ordered.push_back(job.get());
  std::sort(ordered.begin(), ordered.end(), [](const Job* a, const Job* b) { return a->servedBefore(*b); });
  std::vector<JobInfo> out;
  for (const Job* j : ordered) out.push_back(infoOf(*j));
  return out;
}

JobInfo Coordinator::waitForChange(const std::string& jobId, uint64_t afterVersion, double timeoutSeconds) const {
  MutexLock lock(mutex_);
  findJob(jobId);
  // The job is looked up again after every wake: it may have been deleted meanwhile.
  lock.waitFor(changed_, std::chrono::duration<double>(timeoutSeconds), [&] {
    mutex_.assertHeld();  // the wait runs it with the lock held
    const auto it = jobs_.find(jobId);
    return it == jobs_.end() || it->second->progress.version > afterVersion;
  });
  return infoOf(findJob(jobId));
}

void Coordinator::touch(Job& job) {
  ++job.progress.version;
  changed_.notify_all();
}

void Coordinator::end(Job& job, JobState state) {
  if (!job.audit.audits.empty())
    job.addEvent(std::to_string(job.audit.audits.size()) + " audit(s) not settled: the job ended (" +
                 jobStateName(state) + ")");
  job.audit.audits.clear();
  job.audit.stopAwaitingAudits.reset();
  job.progress.state = state;
  job.progress.finished = Clock::now();
  share_.forgetJob(job.definition.owner, job.definition.id);
  if (state == JobState::kDone && job.progress.stopReason == "target error reached")
    notify(job, farm_event::kJobTargetReached, job.progress.stopReason);
  notify(job,
         state == JobState::kDone     ? farm_event::kJobDone
         : state == JobState::kFailed ? farm_event::kJobFailed
                                      : farm_event::kJobCancelled,
         state == JobState::kFailed ? job.progress.error : job.progress.stopReason);
  job.retention.endedUnixSeconds =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  lifecycleDue_ = true;  // archive it, or delete it, when its time comes
  lifecycleWake_.notify_all();
  revokeLeasesOf(job);
  persistState(job);
}

void Coordinator::finish(Job& job, const std::string& reason) {
  job.progress.stopReason = reason;
  end(job, JobState::kDone);
  checkpointWake_.notify_all();  // save the finished image soon
  spdlog::info("job {}: done ({}), {} spp in {} units", job.definition.id, reason, job.progress.samplesPerPixelDone,
               job.progress.unitsAdded);
}

JobInfo Coordinator::cancel(const std::string& jobId) {
  MutexLock lock(mutex_);
  Job& job = findJob(jobId);
  if (!isTerminal(job.progress.state)) {
    end(job, JobState::kCancelled);
    spdlog::info("job {}: cancelled after {} of {} units", job.definition.id, job.progress.unitsAdded,
                 job.progress.units.total());
    touch(job);
  }
  return infoOf(job);
}

ImageMetadata Coordinator::metadataOf(const Job& job) const {
  ImageMetadata metadata;
  metadata.sceneHash = job.definition.sceneHash;
  metadata.rendererVersion = kRendererVersion;
  metadata.extra["job"] = job.definition.id;
  metadata.extra["scene"] = job.definition.spec.sceneName;
  metadata.extra["integrator"] = integratorName(job.definition.settings.integrator);
  metadata.extra["maxBounces"] = std::to_string(job.definition.settings.maxBounces);
  metadata.extra["seed"] = std::to_string(job.definition.settings.seed);
  std::string provenance;
  for (const auto& [name, units] : job.progress.unitsByWorker)
    provenance += (provenance.empty() ? "" : ", ") + name + ": " + std::to_string(units) + " units";
  metadata.extra["workers"] = provenance;
  // What rendered it, beside who (docs/farm.md "Mixed machines").
  metadata.extra["kernel"] = job.kernel;
  std::string builds;
  for (const auto& [build, units] : job.progress.unitsByBuild)
    builds += (builds.empty() ? "" : "; ") + build + ": " + std::to_string(units) + " units";
  metadata.extra["builds"] = builds;
  std::string effects;
  for (const auto& e : job.definition.effects) effects += (effects.empty() ? "" : "; ") + e;
  metadata.extra["effects"] = effects;
  metadata.renderSeconds = elapsedSecondsOf(job);
  return metadata;
}

JobImage Coordinator::image(const std::string& jobId, std::optional<int64_t> frame) const {
  // The image's memory first, waiting for room, before the job is pinned (archiving a job frees
  // room and waits for its pins): concurrent downloads of large images take turns.
  RenderSettings settings;
  {
    MutexLock lock(mutex_);
    settings = findJob(jobId).definition.settings;
  }
  MemoryBudget::Reservation memory = reserveImage(settings, "an image of " + jobId);
  JobPin pin;  // the job and its film stay while the image is made (lifecycle.cpp)
  const Job* job;
  bool archived;
  {
    MutexLock lock(mutex_);
    Job& found = findJobNotArchiving(lock, jobId);  // an image being archived is served from the archive
    pin = JobPin(*this, found);
    job = &found;
    archived = found.retention.archived;
  }
  // An animation's frames are stored as they complete (frame_store.h), archived or not.
  JobImage out = archived && !job->definition.layout.frames ? archivedImage(*job) : developedImage(*job, frame);
  out.memory = std::move(memory);
  return out;
}

Coordinator::Job& Coordinator::findJobNotArchiving(MutexLock& lock, const std::string& jobId) const {
  lock.wait(changed_, [&] {
    mutex_.assertHeld();  // the wait runs it with the lock held
    const auto it = jobs_.find(jobId);
    return it == jobs_.end() || !it->second->retention.archiving;
  });
  return findJob(jobId);
}

std::unique_ptr<std::istream> Coordinator::archivedExr(const std::string& jobId, uint64_t* size) const {
  JobPin pin;
  {
    MutexLock lock(mutex_);
    Job& found = findJobNotArchiving(lock, jobId);
    if (!found.retention.archived || found.definition.layout.frames) return nullptr;
    pin = JobPin(*this, found);
  }
  return archive_->open(jobId, size);
}

std::filesystem::path Coordinator::spoolDirectory() const {
  return options_.stateDir.empty() ? std::filesystem::temp_directory_path() : options_.stateDir;
}

MemoryBudget::Reservation Coordinator::reserveImage(const RenderSettings& settings, const std::string& what) const {
  const uint64_t bytes = imageMemory(settings);
  std::optional<MemoryBudget::Reservation> reserved =
      memory_->reserve(bytes, what, std::chrono::milliseconds(int64_t(options_.imageWaitSeconds * 1000.0)));
  if (!reserved)
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    what + " needs " + formatBytes(bytes) + " of coordinator memory, and for " +
                        fmt::format("{:g} s", options_.imageWaitSeconds) + " the coordinator " + memoryBudgetText() +
                        "; try again when other downloads have ended");
  return std::move(*reserved);
}

JobImage Coordinator::developedImage(const Job& jobRef, std::optional<int64_t> frame) const {
  JobImage out;
  const Job* job = &jobRef;
  uint64_t frameIndex = 0;
  {
    MutexLock lock(mutex_);
    out.exposure = job->definition.settings.exposure;
    out.metadata = metadataOf(*job);
    if (frame) {
      const std::optional<FrameRange>& range = job->definition.layout.frames;
      const int64_t first = range ? range->first : 0, step = range ? range->step : 1;
      const int64_t last = range ? range->last : 0;
      if (*frame < first || *frame > last || (*frame - first) % step != 0)
        throw FarmError(FarmError::Kind::kNotFound,
                        job->definition.id + " has no frame " + std::to_string(*frame) +
                            (range ? " (its frames: " + std::to_string(first) + "-" + std::to_string(last) +
                                         (step > 1 ? "x" + std::to_string(step) : "") + ")"
                                   : " (a still)"));
      frameIndex = uint64_t((*frame - first) / step);
    }
    if (job->definition.layout.frames)
      out.metadata.extra["frame"] = std::to_string(job->definition.layout.frameNumber(frameIndex));
  }
  Accumulator::Developed developed;
  try {
    if (job->definition.layout.frames) {
      // An animation frame: held while its tiles arrive, then stored (frame_store.h).
      std::optional<Accumulator::Developed> held =
          job->film ? job->film->developFrame(frameIndex) : std::optional<Accumulator::Developed>{};
      if (held) {
        developed = std::move(*held);
      } else {
        ImageMetadata stored;
        std::optional<Image> image = frames_->read(job->definition.id, frameIndex, &stored);
        if (!image)
          throw FarmError(FarmError::Kind::kFailedPrecondition,
                          job->definition.id + ": frame " + out.metadata.extra["frame"] + " has no tile rendered yet");
        developed.image = std::move(*image);
        developed.samplesPerPixel = stored.samplesPerPixel;
        developed.totalSamples = stored.totalSamples;
        developed.stats.rays = stored.extra.count("rays") ? std::stoull(stored.extra["rays"]) : 0;
        developed.stats.dropped =
            stored.extra.count("droppedSamples") ? std::stoull(stored.extra["droppedSamples"]) : 0;
      }
    } else {
      developed = job->film->develop();
    }
    applyDiffraction(job->definition.diffraction.get(),
                     developed.image);  // the same image for the farm and `lensfarm render`
  } catch (const std::bad_alloc&) {
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    "out of memory developing the image of " + job->definition.id + " (" +
                        formatBytes(uint64_t(job->definition.settings.width) * job->definition.settings.height *
                                    kImageBytesPerCell) +
                        ")");
  }
  out.image = std::move(developed.image);
  out.metadata.samplesPerPixel = developed.samplesPerPixel;
  out.metadata.totalSamples = developed.totalSamples;
  out.metadata.extra["rays"] = std::to_string(developed.stats.rays);
  out.metadata.extra["droppedSamples"] = std::to_string(developed.stats.dropped);
  return out;
}

std::string Coordinator::sensorState(const std::string& jobId) const {
  JobPin pin;
  const Job* job;
  {
    MutexLock lock(mutex_);
    Job& found = findJob(jobId);
    if (found.retention.filmReleased())
      throw FarmError(FarmError::Kind::kFailedPrecondition, jobId + " is archived: its sensor was freed");
    pin = JobPin(*this, found);
    job = &found;
  }
  return job->film->serializedSensor();
}

JobSpec Coordinator::jobSpec(const std::string& jobId) const {
  MutexLock lock(mutex_);
  return findJob(jobId).definition.spec;
}

JobSpec Coordinator::jobSpecFor(const std::string& workerId, const std::string& jobId) const {
  MutexLock lock(mutex_);
  const Job& job = findJob(jobId);
  for (const LeaseTable::Lease* lease : leases_.ofJob(jobId))
    if (lease->workerId == workerId) return job.definition.spec;
  if (const WorkerRecord* worker = workers_.known(workerId); worker && worker->prefetched.count(jobId))
    return job.definition.spec;  // asked to fetch it ahead (takePrefetch)
  throw FarmError(FarmError::Kind::kFailedPrecondition, workerId + " holds no lease of " + jobId);
}

std::shared_ptr<const std::string> Coordinator::assetFor(const std::string& workerId, const std::string& sha256) {
  {
    MutexLock lock(mutex_);
    bool held = false;
    const WorkerRecord* worker = workers_.known(workerId);
    for (const auto& [id, job] : jobs_) {
      bool jobHeld = worker && worker->prefetched.count(id);  // asked to fetch it ahead
      for (const LeaseTable::Lease* lease : leases_.ofJob(id)) jobHeld |= lease->workerId == workerId;
      if (!jobHeld) continue;
      for (const auto& [path, sha] : job->definition.spec.assets) held |= sha == sha256;
    }
    if (!held)
      throw FarmError(FarmError::Kind::kFailedPrecondition,
                      "asset " + sha256.substr(0, 12) + " belongs to no job " + workerId + " holds a lease of");
  }
  return asset(sha256);
}

void Coordinator::checkOwnerQuotas(const std::string& owner, const JobSpec& spec, uint64_t pixelSamples) const {
  if (!options_.maxAssetBytesPerOwner && !options_.maxSamplesPerOwner) return;
  const std::string who = owner.empty() ? std::string("the unnamed owner") : "owner " + logText(owner);
  std::set<std::string> assets;
  double outstanding = double(pixelSamples);
  for (const auto& [id, j] : jobs_) {
    if (j->definition.owner != owner) continue;
    for (const auto& [path, sha] : j->definition.spec.assets) assets.insert(sha);
    if (isTerminal(j->progress.state)) continue;
    const JobLayout& l = j->definition.layout;
    const double total = double(l.width) * double(l.height) * double(l.samplesPerPixel) * double(l.frameCount());
    const uint64_t units = j->progress.units.total();
    outstanding += units ? total * double(units - std::min(units, j->progress.unitsAdded)) / double(units) : 0.0;
  }
  for (const auto& [path, sha] : spec.assets) assets.insert(sha);
  uint64_t bytes = 0;
  for (const std::string& sha : assets) bytes += assets_.sizeOf(sha);
  if (options_.maxAssetBytesPerOwner && bytes > options_.maxAssetBytesPerOwner)
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    spec.sceneName + ": " + who + "'s jobs would refer to " + formatBytes(bytes) +
                        " of assets, above " + formatBytes(options_.maxAssetBytesPerOwner) +
                        " an owner may (--max-asset-bytes-per-owner); delete jobs no longer needed");
  if (options_.maxSamplesPerOwner && outstanding > double(options_.maxSamplesPerOwner))
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    spec.sceneName + ": " + who + "'s queued and running jobs would have " +
                        fmt::format("{:.3g}", outstanding) + " pixel-samples to render, above the " +
                        fmt::format("{:.3g}", double(options_.maxSamplesPerOwner)) +
                        " an owner may (--max-samples-per-owner); wait for some to end or cancel them");
}

// ---- dashboard ------------------------------------------------------------------------------

JobInfo Coordinator::setPriority(const std::string& jobId, int priority) {
  JobUpdate update;
  update.priority = priority;
  return updateJob(jobId, update);
}

std::vector<ErrorPoint> Coordinator::errorHistory(const std::string& jobId) const {
  MutexLock lock(mutex_);
  return findJob(jobId).progress.history;
}

MetricsSnapshot Coordinator::metricsSnapshot() const {
  MetricsSnapshot s;
  s.jobs = jobs();
  s.workers = workers();
  {
    MutexLock lock(mutex_);
    s.leasesActive = leases_.size();
  }
  s.unitsLeased = counters_.unitsLeased;
  s.backupLeases = counters_.backupLeases;
  s.unitsDone = counters_.unitsDone;
  s.unitsExpired = counters_.unitsExpired;
  s.workersLost = counters_.workersLost;
  s.stateWriteFailures = counters_.stateWriteFailures;
  {
    MutexLock lock(mutex_);
    s.stateWritesStalled = storageStall_.has_value();
  }
  s.auditsPassed = counters_.auditsPassed;
  s.auditsFailed = counters_.auditsFailed;
  s.auditsExplained = counters_.auditsExplained;
  s.unitsRerendered = counters_.unitsRerendered;
  s.samples = counters_.samples;
  s.unitBytesReceived = counters_.unitBytes;
  s.unitWireBytesReceived = counters_.unitWireBytes;
  const AssetStore::Counts assets = assets_.counts();
  s.assetBytesReceived = assets.bytesReceived;
  s.assetsSent = assets.sent;
  s.assetsCollected = assets.collected;
  s.assetBytesStored = assets_.storedBytes();
  s.assetBytesResident = assets_.residentBytes();
  s.memoryBudgetBytes = memory_->total();
  s.memoryReservedBytes = memory_->reserved();
  s.assetUploadsStored = assets.uploadsStored;
  s.assetUploadsPresent = assets.uploadsPresent;
  s.leaseTimeoutSeconds = options_.leaseTimeoutSeconds;
  return s;
}

}  // namespace lensfarm
