// Coordinator, part one: assets, jobs, the unit scheduler and its leases, accumulation in unit
// order, durable state. The workers and their liveness are in workers.cpp.
#include "coordinator.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <random>
#include <cmath>

#include "render/memory_estimate.h"
#include "scene/effects.h"
#include "scene/scene_loader.h"
#include "util/error.h"
#include "util/hash.h"
#include "util/version.h"
#include "coordinator_records.h"
#include "state_store.h"

namespace lensfarm {

namespace {
bool isSha256Hex(const std::string& text) {
  return text.size() == 64 &&
         std::all_of(text.begin(), text.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

// A client's string in an error message: at most 80 characters, control characters as '?'.
std::string shown(const std::string& text) {
  std::string out = text.substr(0, 80);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return text.size() > 80 ? out + "..." : out;
}

std::vector<std::string> describeEffects(const Scene& scene) {
  std::vector<std::string> out;
  for (const auto& d : analyzeEffects(scene, scene.camera()).decisions)
    out.push_back(d.effect + ": " + (d.simulated ? "on" : "off") + " (" + d.reason + ")");
  return out;
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

namespace {
// Appends the job's published estimate to its curve when it changed (requires mutex_).
template <class JobT>
void recordEstimate(JobT& job, double elapsedSeconds) {
  if (!job.estimate.valid) return;
  auto& h = job.history;
  // A job without a target re-estimates a few times a second, not every unit: a point whose
  // estimate did not change would be stale, so only new estimates make points.
  if (!h.empty() && h.back().relativeError == job.estimate.relativeRmse) return;
  if (h.size() >= Coordinator::kMaxErrorPoints) {
    size_t kept = 0;
    for (size_t i = 0; i < h.size(); i += 2) h[kept++] = h[i];
    h.resize(kept);
  }
  h.push_back(ErrorPoint{elapsedSeconds, job.estimate.relativeRmse, job.samplesPerPixelDone});
}
}  // namespace

Coordinator::Coordinator(Options options) : options_(std::move(options)) {
  if (options_.maxJobMemoryBytes == 0) {
    options_.maxJobMemoryBytes = defaultJobMemoryBudget();
    options_.maxJobMemorySource = defaultJobMemoryBudgetSource();
  }
  if (options_.stateDir.empty()) {
    epoch_ = std::random_device{}() & 0xfffff;
    nextLease_ = (epoch_ << 40) + 1;
    return;
  }
  store_ = std::make_unique<StateStore>(options_.stateDir);
  epoch_ = store_->bootCount();
  restore();
  checkpointer_ = std::thread([this] { checkpointLoop(); });
}

Coordinator::Coordinator() : Coordinator(Options{}) {}

Coordinator::~Coordinator() {
  if (!store_) return;
  {
    std::lock_guard lock(mutex_);
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

void Coordinator::persistState(const Job& job) {
  if (store_) store_->updateJobState(job.id, jobStateName(job.state), job.error, job.stopUnits, job.stopReason);
}

void Coordinator::checkpointLoop() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    checkpointWake_.wait_for(lock, std::chrono::duration<double>(options_.checkpointEverySeconds));
    if (stopping_) break;
    lock.unlock();
    try {
      checkpoint();
    } catch (const std::exception& e) {
      spdlog::error("checkpoint failed (the ledger still holds every unit): {}", e.what());
    }
    lock.lock();
  }
}

uint64_t Coordinator::checkpoint() {
  if (!store_) return 0;
  std::vector<Job*> all;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, job] : jobs_) all.push_back(job.get());
  }
  uint64_t bytes = 0;
  for (Job* job : all) {
    std::string sensor, tracker;
    uint64_t folded;
    {
      std::lock_guard accumulate(job->accumulate);
      if (job->nextToAdd == job->checkpointed) continue;
      sensor = job->sensor->serialize();
      tracker = job->tracker->serialize();
      folded = job->nextToAdd;
    }
    store_->writeCheckpoint(job->id, sensor, tracker, folded);
    bytes += sensor.size();
    std::lock_guard accumulate(job->accumulate);
    job->checkpointed = std::max(job->checkpointed, folded);
  }
  return bytes;
}

void Coordinator::drainInOrder(Job& job, const UnitResult* next) {
  const double target = job.settings.targetError;
  bool folded = false;
  while (job.nextToAdd < job.foldLimit) {
    // The next unit: the caller's (summed from its buffer, never copied) or one that waited.
    const UnitResult* r = nullptr;
    auto it = job.arrived.end();
    if (next && next->unitIndex == job.nextToAdd) {
      r = next;
      next = nullptr;
    } else if (it = job.arrived.find(job.nextToAdd); it != job.arrived.end()) {
      r = &it->second;
    } else {
      break;
    }
    // Every cell of a unit holds the unit's samples; the count is the coordinator's to know.
    const uint32_t samples = unitAt(job.nextToAdd, job.settings.samplesPerPixel, job.unitSize).sampleCount;
    job.sensor->add(r->buffer, samples);
    job.tracker->add(job.nextToAdd, r->buffer, samples);
    job.statsAdded += r->stats;
    job.sppAdded += samples;
    if (it != job.arrived.end()) job.arrived.erase(it);
    ++job.nextToAdd;
    folded = true;
    // A target-error job checks after every unit: the first prefix that reaches the target is
    // the image, whichever units arrived early.
    if (target > 0.0) {
      job.estimateAdded = job.tracker->estimate(*job.sensor);
      job.estimatedAt = Clock::now();
      if (job.estimateAdded.valid && job.estimateAdded.relativeRmse <= target) job.stopFolding("target error reached");
    }
    if (job.stopAtNextFold && job.stopReasonAdded.empty()) job.stopFolding("deadline reached");
  }
  if (job.nextToAdd == job.unitsTotal && job.stopReasonAdded.empty())
    job.stopReasonAdded = target > 0.0 ? "sample cap reached before the target error" : "all samples done";
  // Otherwise the estimate is for people watching: a few times a second is enough (it reads the
  // whole frame), and always at the end.
  const auto now = Clock::now();
  if (folded && target <= 0.0 &&
      (now - job.estimatedAt > std::chrono::milliseconds(250) || !job.stopReasonAdded.empty())) {
    job.estimateAdded = job.tracker->estimate(*job.sensor);
    job.estimatedAt = now;
  }
}

void Coordinator::finish(Job& job, const std::string& reason) {
  job.state = JobState::kDone;
  job.finished = Clock::now();
  job.stopReason = reason;
  revokeLeasesOf(job);
  persistState(job);
  checkpointWake_.notify_all();  // save the finished image soon
  spdlog::info("job {}: done ({}), {} spp in {} units", job.id, reason, job.samplesPerPixelDone, job.unitsAdded);
}

void Coordinator::enforceDeadlines() {
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  for (auto& [id, jobPtr] : jobs_) {
    Job& job = *jobPtr;
    if (job.deadlinePassed || isTerminal(job.state) || job.settings.timeLimitSeconds <= 0.0 ||
        nowUnix < job.submittedUnixSeconds + job.settings.timeLimitSeconds)
      continue;
    job.deadlinePassed = true;
    {
      std::lock_guard accumulate(job.accumulate);
      if (job.nextToAdd == 0) {
        job.stopAtNextFold = true;  // no image yet: the first whole pass is the image
        spdlog::warn("job {}: deadline passed before the first unit was added; stopping after it", job.id);
        continue;
      }
      if (job.stopReasonAdded.empty()) job.stopFolding("deadline reached");
      job.unitsAdded = job.nextToAdd;
      job.samplesPerPixelDone = job.sppAdded;
      job.stats = job.statsAdded;
      job.estimate = job.estimateAdded = job.tracker->estimate(*job.sensor);
      job.stopUnits = job.foldLimit;
    }
    finish(job, "deadline reached");
    recordEstimate(job, elapsedSecondsOf(job));
    touch(job);
  }
}

static JobState parseJobState(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kCancelled, JobState::kFailed})
    if (name == jobStateName(s)) return s;
  throw std::runtime_error("unknown job state " + name);
}

void Coordinator::restore() {
  assets_ = store_->loadAssets();
  const auto now = Clock::now();
  const auto restoreJob = [&](StateStore::StoredJob& stored) {
    auto job = std::make_unique<Job>();
    job->id = stored.id;
    job->spec = stored.spec;
    job->priority = stored.priority;
    job->sequence = stored.sequence;
    job->submittedUnixSeconds = stored.submittedUnixSeconds;
    job->state = parseJobState(stored.state);
    job->error = stored.error;
    job->stopUnits = stored.stopUnits;
    job->stopReason = stored.stopReason;
    if (stored.stopUnits) job->foldLimit = *stored.stopUnits;
    const AssetReader reader = [&](const std::string& path) -> std::optional<std::string> {
      auto it = job->spec.assets.find(path);
      if (it == job->spec.assets.end() || !assets_.count(it->second)) return std::nullopt;
      return *assets_.at(it->second);
    };
    Scene scene = parseScene(job->spec.sceneJson, job->spec.sceneName, reader);
    applyOverrides(job->spec.overrides, scene.render, job->spec.sceneName);
    job->settings = scene.render;
    job->sceneHash = scene.hash;
    job->unitSize = unitSize(scene.render);
    job->unitsTotal = unitCount(scene.render.samplesPerPixel, job->unitSize);
    job->effects = describeEffects(scene);
    job->unitMemoryBytes = workerJobMemory(scene.render, storedTriangles(scene), sceneDataBytes(scene)).total();

    // The checkpoint holds units [0, folded); the ledger lists every accepted unit.
    const auto checkpoint = store_->loadCheckpoint(job->id);
    job->sensor = std::make_unique<Sensor>(checkpoint ? Sensor::deserialize(checkpoint->sensorBytes)
                                                      : Sensor(scene.render.width, scene.render.height));
    job->tracker = std::make_unique<ConvergenceTracker>(
        checkpoint ? ConvergenceTracker::deserialize(checkpoint->trackerBytes)
                   : ConvergenceTracker(scene.render.width, scene.render.height));
    const uint64_t folded = checkpoint ? checkpoint->foldedUnits : 0;
    job->nextToAdd = job->checkpointed = folded;
    for (uint64_t u = 0; u < folded; ++u) job->sppAdded += unitAt(u, job->settings.samplesPerPixel, job->unitSize).sampleCount;
    uint64_t highest = 0;
    bool any = false;
    for (const auto& entry : store_->ledger(job->id)) {
      job->markReceived(entry.unit);
      ++job->unitsByWorker[entry.worker];
      highest = std::max(highest, entry.unit);
      any = true;
      if (entry.unit < folded) {
        job->statsAdded += entry.stats;
        continue;
      }
      UnitResult r;
      r.jobId = job->id;
      r.unitIndex = entry.unit;
      r.stats = entry.stats;
      r.buffer.width = scene.render.width;  // the counts are the coordinator's (drainInOrder)
      r.buffer.height = scene.render.height;
      r.buffer.sums = store_->loadUnitSums(job->id, entry.unit, size_t(scene.render.width) * scene.render.height * 3);
      job->arrived.emplace(entry.unit, std::move(r));
    }
    drainInOrder(*job);
    // Units leased before the restart and never acknowledged go back to the queue.
    job->nextFresh = any ? highest + 1 : 0;
    for (uint64_t u = job->receivedBelow; any && u < highest; ++u)
      if (!job->isReceived(u)) job->returned.insert(u);
    if (isTerminal(job->state)) job->clearPending();
    job->unitsAdded = job->nextToAdd;
    job->samplesPerPixelDone = job->sppAdded;
    job->stats = job->statsAdded;
    job->estimateAdded = job->tracker->estimate(*job->sensor);
    job->estimate = job->estimateAdded;
    if (any) job->started = now;  // elapsed time restarts with the coordinator (docs/farm.md)
    if (isTerminal(job->state)) job->started = job->finished = now;
    if (job->state == JobState::kRunning && !job->stopReasonAdded.empty()) {
      // It reached its stop before the restart (or in the replay): same units, same image.
      job->state = JobState::kDone;
      job->stopReason = job->stopReasonAdded;
      if (job->nextToAdd < job->unitsTotal) job->stopUnits = job->foldLimit = job->nextToAdd;
      job->clearPending();
      persistState(*job);
    }
    nextJob_ = std::max(nextJob_, uint64_t(std::stoull(job->id.substr(4))) + 1);
    nextSequence_ = std::max(nextSequence_, job->sequence + 1);
    spdlog::info("restored {}: {}, {} of {} units ({} from the checkpoint)", job->id, jobStateName(job->state),
                 job->unitsAdded, job->unitsTotal, folded);
    jobs_[job->id] = std::move(job);
  };
  for (StateStore::StoredJob& stored : store_->loadJobs()) {
    try {
      restoreJob(stored);
    } catch (const std::bad_alloc&) {
      // One job that no longer fits in memory stays out (and in the state dir), not the coordinator.
      jobs_.erase(stored.id);
      nextJob_ = std::max(nextJob_, uint64_t(std::stoull(stored.id.substr(4))) + 1);
      nextSequence_ = std::max(nextSequence_, stored.sequence + 1);
      spdlog::error("cannot restore {}: out of memory for its buffers; it stays in the state directory", stored.id);
    }
  }
  nextLease_ = (epoch_ << 40) + 1;
}

// ---- assets ---------------------------------------------------------------------------------

bool Coordinator::hasAsset(const std::string& sha256) const {
  std::lock_guard lock(mutex_);
  return assets_.count(sha256) > 0;
}

bool Coordinator::putAsset(const std::string& sha256, std::string bytes) {
  counters_.assetBytes += bytes.size();
  const std::string actual = sha256Hex(bytes);
  if (actual != sha256)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "asset " + sha256 + ": the uploaded bytes hash to " + actual + " (corrupted upload?)");
  if (uploadFindsAssetPresent(sha256)) return false;
  if (store_) store_->putAsset(sha256, bytes);
  std::lock_guard lock(mutex_);
  const bool stored = assets_.emplace(sha256, std::make_shared<const std::string>(std::move(bytes))).second;
  ++(stored ? counters_.assetUploadsStored : counters_.assetUploadsPresent);  // two uploads of it at once: one stored
  return stored;
}

bool Coordinator::uploadFindsAssetPresent(const std::string& sha256) {
  std::lock_guard lock(mutex_);
  if (!assets_.count(sha256)) return false;
  ++counters_.assetUploadsPresent;
  return true;
}

std::vector<std::string> Coordinator::missingAssets(const std::vector<std::string>& sha256s) const {
  if (sha256s.size() > kMaxAssetQuery)
    throw FarmError(FarmError::Kind::kInvalidArgument, std::to_string(sha256s.size()) +
                                                           " hashes in one query; at most " +
                                                           std::to_string(kMaxAssetQuery) + " (ask in batches)");
  for (size_t i = 0; i < sha256s.size(); ++i)
    if (!isSha256Hex(sha256s[i]))
      throw FarmError(FarmError::Kind::kInvalidArgument, "sha256[" + std::to_string(i) + "]: \"" + shown(sha256s[i]) +
                                                             "\" is not a SHA-256 (64 lowercase hex digits)");
  std::vector<std::string> missing;
  std::set<std::string> seen;
  std::lock_guard lock(mutex_);
  for (const std::string& sha : sha256s)
    if (!assets_.count(sha) && seen.insert(sha).second) missing.push_back(sha);
  return missing;
}

std::shared_ptr<const std::string> Coordinator::storedAsset(const std::string& sha256) const {
  std::lock_guard lock(mutex_);
  auto it = assets_.find(sha256);
  if (it == assets_.end()) throw FarmError(FarmError::Kind::kNotFound, "no asset " + sha256);
  return it->second;
}

std::shared_ptr<const std::string> Coordinator::asset(const std::string& sha256) {
  std::shared_ptr<const std::string> bytes = storedAsset(sha256);
  ++counters_.assetsSent;
  return bytes;
}

// ---- jobs -----------------------------------------------------------------------------------

JobInfo Coordinator::submit(const JobSpec& spec, int priority) {
  {
    std::lock_guard lock(mutex_);
    std::string missing;
    for (const auto& [path, sha] : spec.assets)
      if (!assets_.count(sha)) missing += (missing.empty() ? "" : ", ") + path + " (" + sha.substr(0, 12) + ")";
    if (!missing.empty())
      throw FarmError(FarmError::Kind::kFailedPrecondition, "assets not uploaded: " + missing);
  }
  // Load the scene exactly as a worker will, to validate it and fix its settings and hash.
  const AssetReader reader = [&](const std::string& path) -> std::optional<std::string> {
    auto it = spec.assets.find(path);
    if (it == spec.assets.end()) return std::nullopt;
    return *storedAsset(it->second);
  };
  Scene scene = parseScene(spec.sceneJson, spec.sceneName, reader);
  applyOverrides(spec.overrides, scene.render, spec.sceneName);
  (void)scene.camera();  // validates the camera at the final resolution
  for (const auto& [path, sha] : scene.assets)
    if (!spec.assets.count(path) || spec.assets.at(path) != sha)
      throw FarmError(FarmError::Kind::kInvalidArgument, "asset " + path + " is not listed in the job spec");

  // Refuse what this coordinator cannot hold before allocating anything frame-sized.
  const MemoryEstimate memory = coordinatorJobMemory(scene.render, options_.maxBytesAhead, store_ != nullptr);
  if (memory.total() > options_.maxJobMemoryBytes)
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    spec.sceneName + ": " +
                        overBudgetMessage(scene.render, memory, "coordinator", options_.maxJobMemoryBytes,
                                          options_.maxJobMemorySource) +
                        "; lower the resolution (--resolution) or give the coordinator more (--max-job-memory)");

  auto job = std::make_unique<Job>();
  job->spec = spec;
  job->priority = priority;
  job->settings = scene.render;
  job->sceneHash = scene.hash;
  job->unitSize = unitSize(scene.render);
  job->unitsTotal = unitCount(scene.render.samplesPerPixel, job->unitSize);
  job->effects = describeEffects(scene);
  job->unitMemoryBytes = workerJobMemory(scene.render, storedTriangles(scene), sceneDataBytes(scene)).total();
  try {
    if (options_.beforeJobAllocation) options_.beforeJobAllocation(memory.total());
    job->sensor = std::make_unique<Sensor>(scene.render.width, scene.render.height);
    job->tracker = std::make_unique<ConvergenceTracker>(scene.render.width, scene.render.height);
  } catch (const std::bad_alloc&) {
    // This job is refused; the coordinator and its other jobs go on.
    const std::string what = spec.sceneName + ": out of memory allocating the " + std::to_string(scene.render.width) +
                             "x" + std::to_string(scene.render.height) + " job's sensor (estimated " +
                             formatBytes(memory.total()) + " in all); the job was not queued";
    spdlog::error("SubmitJob: {}", what);
    throw FarmError(FarmError::Kind::kResourceExhausted, what);
  }
  job->submittedUnixSeconds =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();

  std::lock_guard lock(mutex_);
  job->id = "job-" + std::to_string(nextJob_++);
  job->sequence = nextSequence_++;
  if (store_)
    store_->insertJob(StateStore::StoredJob{job->id, job->sequence, job->priority, job->spec, jobStateName(job->state),
                                            "", job->submittedUnixSeconds, 0, std::nullopt, ""});
  spdlog::info("job {}: {} {}x{}, {} spp in {} units of {}, priority {}", job->id, spec.sceneName,
               job->settings.width, job->settings.height, job->settings.samplesPerPixel, job->unitsTotal,
               job->unitSize, priority);
  Job& ref = *job;
  jobs_[job->id] = std::move(job);
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
  if (it == jobs_.end()) throw FarmError(FarmError::Kind::kNotFound, "no job " + jobId);
  return *it->second;
}

double Coordinator::elapsedSecondsOf(const Job& job) {
  if (!job.started) return 0.0;
  return std::chrono::duration<double>(job.finished.value_or(Clock::now()) - *job.started).count();
}

JobInfo Coordinator::infoOf(const Job& job) const {
  JobInfo info;
  info.id = job.id;
  info.state = job.state;
  info.priority = job.priority;
  info.sceneName = job.spec.sceneName;
  info.sceneHash = job.sceneHash;
  info.width = job.settings.width;
  info.height = job.settings.height;
  info.samplesPerPixelDone = job.samplesPerPixelDone;
  info.samplesPerPixelTotal = job.settings.samplesPerPixel;
  info.unitsDone = job.unitsAdded;
  info.unitsTotal = job.unitsTotal;
  info.stats = job.stats;
  info.elapsedSeconds = elapsedSecondsOf(job);
  const double fraction = job.unitsTotal ? double(job.unitsAdded) / double(job.unitsTotal) : 0.0;
  if (!isTerminal(job.state) && fraction > 0.0) info.remainingSeconds = info.elapsedSeconds * (1.0 - fraction) / fraction;
  info.estimatedRelativeError = job.estimate.valid ? job.estimate.relativeRmse : -1.0;
  info.targetError = job.settings.targetError;
  info.timeLimitSeconds = job.settings.timeLimitSeconds;
  info.stopReason = job.stopReason;
  if (!isTerminal(job.state) && job.estimate.valid && info.targetError > 0.0) {
    info.secondsToTarget = secondsToTarget(job.estimate.relativeRmse, info.targetError, info.elapsedSeconds);
    info.remainingSeconds = std::min(info.remainingSeconds, info.secondsToTarget);
  }
  if (!isTerminal(job.state) && info.timeLimitSeconds > 0.0) {
    const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    const double left = std::max(0.0, job.submittedUnixSeconds + info.timeLimitSeconds - nowUnix);
    info.remainingSeconds = info.remainingSeconds > 0.0 ? std::min(info.remainingSeconds, left) : left;
  }
  for (const auto& [id, lease] : leases_)
    if (lease.jobId == job.id) ++info.workersBusy;
  info.error = job.error;
  info.submittedUnixSeconds = job.submittedUnixSeconds;
  info.version = job.version;
  info.effects = job.effects;
  info.stalledReason = stalledReason(job, Clock::now());
  info.progressFraction = progressFraction(info, std::chrono::duration<double>(
                                                     std::chrono::system_clock::now().time_since_epoch()).count());
  return info;
}

JobInfo Coordinator::job(const std::string& jobId) const {
  std::lock_guard lock(mutex_);
  return infoOf(findJob(jobId));
}

std::vector<JobInfo> Coordinator::jobs() const {
  std::lock_guard lock(mutex_);
  std::vector<const Job*> ordered;
  for (const auto& [id, job] : jobs_) ordered.push_back(job.get());
  std::sort(ordered.begin(), ordered.end(), [](const Job* a, const Job* b) {
    return a->priority != b->priority ? a->priority > b->priority : a->sequence < b->sequence;
  });
  std::vector<JobInfo> out;
  for (const Job* j : ordered) out.push_back(infoOf(*j));
  return out;
}

JobInfo Coordinator::waitForChange(const std::string& jobId, uint64_t afterVersion, double timeoutSeconds) const {
  std::unique_lock lock(mutex_);
  const Job& job = findJob(jobId);
  changed_.wait_for(lock, std::chrono::duration<double>(timeoutSeconds),
                    [&] { return job.version > afterVersion; });
  return infoOf(job);
}

void Coordinator::touch(Job& job) {
  ++job.version;
  changed_.notify_all();
}

void Coordinator::revokeLeasesOf(Job& job) {
  for (auto it = leases_.begin(); it != leases_.end();)
    it = it->second.jobId == job.id ? leases_.erase(it) : std::next(it);
  job.clearPending();
}

JobInfo Coordinator::cancel(const std::string& jobId) {
  std::lock_guard lock(mutex_);
  Job& job = findJob(jobId);
  if (!isTerminal(job.state)) {
    job.state = JobState::kCancelled;
    job.finished = Clock::now();
    revokeLeasesOf(job);
    persistState(job);
    spdlog::info("job {}: cancelled after {} of {} units", job.id, job.unitsAdded, job.unitsTotal);
    touch(job);
  }
  return infoOf(job);
}

JobImage Coordinator::image(const std::string& jobId) const {
  JobImage out;
  const Job* job;
  {
    std::lock_guard lock(mutex_);
    job = &findJob(jobId);  // jobs are never removed, so the pointer stays valid
    out.exposure = job->settings.exposure;
    out.metadata.sceneHash = job->sceneHash;
    out.metadata.rendererVersion = kRendererVersion;
    out.metadata.extra["job"] = job->id;
    out.metadata.extra["scene"] = job->spec.sceneName;
    out.metadata.extra["integrator"] = integratorName(job->settings.integrator);
    out.metadata.extra["maxBounces"] = std::to_string(job->settings.maxBounces);
    out.metadata.extra["seed"] = std::to_string(job->settings.seed);
    std::string provenance;
    for (const auto& [name, units] : job->unitsByWorker)
      provenance += (provenance.empty() ? "" : ", ") + name + ": " + std::to_string(units) + " units";
    out.metadata.extra["workers"] = provenance;
    std::string effects;
    for (const auto& e : job->effects) effects += (effects.empty() ? "" : "; ") + e;
    out.metadata.extra["effects"] = effects;
    out.metadata.renderSeconds = elapsedSecondsOf(*job);
  }
  std::lock_guard lock(job->accumulate);
  try {
    out.image = job->sensor->developImage();
  } catch (const std::bad_alloc&) {
    throw FarmError(FarmError::Kind::kResourceExhausted,
                    "out of memory developing the image of " + job->id + " (" +
                        formatBytes(uint64_t(job->settings.width) * job->settings.height * kImageBytesPerCell) + ")");
  }
  out.metadata.samplesPerPixel = job->sppAdded;
  out.metadata.totalSamples = job->sensor->totalSamples();
  out.metadata.extra["rays"] = std::to_string(job->statsAdded.rays);
  out.metadata.extra["droppedSamples"] = std::to_string(job->statsAdded.dropped);
  return out;
}

std::string Coordinator::sensorState(const std::string& jobId) const {
  const Job* job;
  {
    std::lock_guard lock(mutex_);
    job = &findJob(jobId);
  }
  std::lock_guard accumulate(job->accumulate);
  return job->sensor->serialize();
}

// ---- workers --------------------------------------------------------------------------------

void Coordinator::reapExpiredLeases(Clock::time_point now) {
  for (auto it = leases_.begin(); it != leases_.end();) {
    if (it->second.deadline < now) {
      Job& job = findJob(it->second.jobId);
      spdlog::warn("job {}: lease {} of unit {} held by {} lapsed; the unit goes back to the queue", job.id,
                   it->first, it->second.unit, it->second.workerId);
      if (!isTerminal(job.state) && !job.isReceived(it->second.unit)) job.returned.insert(it->second.unit);
      ++counters_.unitsExpired;
      if (auto w = workers_.find(it->second.workerId); w != workers_.end() && w->second->currentJobId == job.id)
        w->second->currentJobId.clear();
      it = leases_.erase(it);
      changed_.notify_all();
    } else {
      ++it;
    }
  }
  enforceDeadlines();
  // Forget workers silent for much longer than a lease: they hold nothing any more.
  const auto forgetAfter = std::chrono::duration<double>(std::max(60.0, 10.0 * options_.leaseTimeoutSeconds));
  for (auto it = workers_.begin(); it != workers_.end();)
    it = now - it->second->lastHeartbeat > forgetAfter ? workers_.erase(it) : std::next(it);
}

std::optional<LeaseGrant> Coordinator::tryLease(Worker& worker, Clock::time_point now) {
  Job* best = nullptr;
  for (auto& [id, job] : jobs_) {
    if (isTerminal(job->state) || !job->hasPending()) continue;
    if (!job->fitsOn(worker.info)) continue;  // its units are for a worker with more memory
    if (job->returned.empty()) {  // a fresh unit: only within the window ahead of the summed prefix
      const uint64_t window = unitsAheadWindow(job->settings.width, job->settings.height, options_.maxBytesAhead);
      if (job->nextFresh >= job->unitsAdded + window) continue;
    }
    if (!best || job->priority > best->priority || (job->priority == best->priority && job->sequence < best->sequence))
      best = job.get();
  }
  if (!best) return std::nullopt;
  Job& job = *best;
  const uint64_t unit = job.takePending();
  const uint64_t leaseId = nextLease_++;
  leases_[leaseId] = ActiveLease{worker.id, job.id, unit,
                                 now + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(options_.leaseTimeoutSeconds))};
  ++counters_.unitsLeased;
  if (!job.started) job.started = now;
  if (job.state == JobState::kQueued) {
    job.state = JobState::kRunning;
    persistState(job);
  }
  worker.currentJobId = job.id;
  worker.currentUnit = unit;
  touch(job);
  return LeaseGrant{leaseId, job.id, unitAt(unit, job.settings.samplesPerPixel, job.unitSize), job.sceneHash,
                    options_.leaseTimeoutSeconds};
}

std::optional<LeaseGrant> Coordinator::lease(const std::string& workerId, double waitSeconds) {
  std::unique_lock lock(mutex_);
  const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(waitSeconds));
  for (;;) {
    Worker& worker = findWorker(workerId);
    const auto now = Clock::now();
    worker.lastHeartbeat = now;
    reapExpiredLeases(now);
    if (auto grant = tryLease(worker, now)) return grant;
    worker.currentJobId.clear();
    worker.currentUnit.reset();
    if (now >= until) return std::nullopt;
    // Wake on new work, and now and then to reap lapsed leases.
    changed_.wait_until(lock, std::min(until, now + std::chrono::milliseconds(200)));
  }
}

JobSpec Coordinator::jobSpec(const std::string& jobId) const {
  std::lock_guard lock(mutex_);
  return findJob(jobId).spec;
}

bool Coordinator::acceptResult(UnitResult&& result) { return accept(result, &result); }

bool Coordinator::acceptResult(const UnitResult& result) { return accept(result, nullptr); }

bool Coordinator::accept(const UnitResult& result, UnitResult* owned) {
  counters_.unitBytes += result.buffer.sums.size() * sizeof(double);
  // Workers drop non-finite samples before they are summed (design.md); a buffer holding one is
  // corrupt and must not reach the sensor. Checked before taking the lock: it reads every cell.
  for (double v : result.buffer.sums)
    if (!std::isfinite(v))
      throw FarmError(FarmError::Kind::kInvalidArgument, "result for unit " + std::to_string(result.unitIndex) +
                                                             " of " + result.jobId + " holds a non-finite sum");
  Job* job;
  std::string workerName;
  {
    std::lock_guard lock(mutex_);
    job = &findJob(result.jobId);
    if (result.unitIndex >= job->unitsTotal)
      throw FarmError(FarmError::Kind::kInvalidArgument, "job " + job->id + " has no unit " + std::to_string(result.unitIndex));
    // A late duplicate of a unit already counted (or being counted) is ignored.
    if (job->isReceived(result.unitIndex) || job->inflight.count(result.unitIndex)) return false;
    auto it = leases_.find(result.leaseId);
    if (it == leases_.end() || it->second.workerId != result.workerId || it->second.jobId != result.jobId ||
        it->second.unit != result.unitIndex)
      throw FarmError(FarmError::Kind::kFailedPrecondition,
                      "lease " + std::to_string(result.leaseId) + " for unit " + std::to_string(result.unitIndex) +
                          " of " + result.jobId + " is not held by " + result.workerId);
    const int w = job->settings.width, h = job->settings.height;
    if (result.buffer.width != w || result.buffer.height != h ||
        result.buffer.sums.size() != size_t(w) * size_t(h) * 3)
      throw FarmError(FarmError::Kind::kInvalidArgument, "result for " + job->id + " has the wrong size");
    Worker& worker = findWorker(result.workerId);
    workerName = worker.info.name.empty() ? worker.id : worker.info.name;
    leases_.erase(it);
    job->inflight.insert(result.unitIndex);
  }

  // Durable before acknowledged: the unit's sums and ledger row, outside the coordinator's lock.
  if (store_) {
    try {
      store_->recordUnit(job->id, StateStore::LedgerEntry{result.unitIndex, workerName, result.stats}, result.buffer.sums);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      job->inflight.erase(result.unitIndex);
      if (!isTerminal(job->state)) job->returned.insert(result.unitIndex);
      spdlog::error("cannot record unit {} of {}: {}", result.unitIndex, job->id, e.what());
      throw;
    }
  }
  {
    std::lock_guard lock(mutex_);
    job->inflight.erase(result.unitIndex);
    job->markReceived(result.unitIndex);
    ++counters_.unitsDone;
    counters_.samples += result.stats.paths;
    if (auto w = workers_.find(result.workerId); w != workers_.end()) {
      ++w->second->unitsDone;
      if (result.renderSeconds > 0.0) w->second->samplesPerSecond = double(result.stats.paths) / result.renderSeconds;
      if (w->second->currentUnit == result.unitIndex) w->second->currentUnit.reset();
    }
    ++job->unitsByWorker[workerName];
  }
  // Sum outside the coordinator's lock: large buffers must not stall leases and heartbeats.
  uint64_t unitsAdded, sppAdded, foldLimit;
  PathStats statsAdded;
  ErrorEstimate estimate;
  std::string stopReason;
  bool outOfMemory = false;
  {
    std::lock_guard accumulate(job->accumulate);
    // Past a job's stop nothing more is folded (the stop is a prefix of units). The next unit in
    // order is summed from the caller's buffer; a later one waits in `arrived`.
    const bool next = result.unitIndex == job->nextToAdd;
    try {
      if (result.unitIndex < job->foldLimit && !next)
        job->arrived.emplace(result.unitIndex, owned ? std::move(*owned) : result);
    } catch (const std::bad_alloc&) {
      outOfMemory = true;
    }
    if (!outOfMemory) drainInOrder(*job, next && result.unitIndex < job->foldLimit ? &result : nullptr);
    unitsAdded = job->nextToAdd;
    sppAdded = job->sppAdded;
    statsAdded = job->statsAdded;
    estimate = job->estimateAdded;
    stopReason = job->stopReasonAdded;
    foldLimit = job->foldLimit;
  }

  std::lock_guard lock(mutex_);
  if (outOfMemory) {
    // The unit is counted but cannot be kept: this job cannot finish; the coordinator and its
    // other jobs go on.
    const std::string what = "coordinator out of memory keeping unit " + std::to_string(result.unitIndex) + " (" +
                             formatBytes(result.buffer.memoryBytes()) + ") until the units before it arrive";
    spdlog::error("job {}: {}", job->id, what);
    if (!isTerminal(job->state)) {
      job->state = JobState::kFailed;
      job->error = what;
      job->finished = Clock::now();
      revokeLeasesOf(*job);
      persistState(*job);
      touch(*job);
    }
    throw FarmError(FarmError::Kind::kResourceExhausted, job->id + ": " + what);
  }
  if (unitsAdded > job->unitsAdded) {
    job->unitsAdded = unitsAdded;
    job->samplesPerPixelDone = sppAdded;
    job->stats = statsAdded;
    job->estimate = estimate;
    recordEstimate(*job, elapsedSecondsOf(*job));
    if (!stopReason.empty() && job->state == JobState::kRunning) {
      if (foldLimit < job->unitsTotal) job->stopUnits = foldLimit;
      finish(*job, stopReason);
    }
    touch(*job);
  }
  return true;
}

void Coordinator::reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                                const std::string& error) {
  std::lock_guard lock(mutex_);
  Job& job = findJob(jobId);
  auto it = leases_.find(leaseId);
  if (it == leases_.end() || it->second.workerId != workerId) return;  // stale report
  if (!isTerminal(job.state)) {
    job.state = JobState::kFailed;
    job.error = workerId + ": " + error;
    job.finished = Clock::now();
    revokeLeasesOf(job);
    persistState(job);
    spdlog::error("job {}: failed on {}: {}", job.id, workerId, error);
    touch(job);
  }
}

// ---- dashboard ------------------------------------------------------------------------------

JobInfo Coordinator::setPriority(const std::string& jobId, int priority) {
  std::lock_guard lock(mutex_);
  Job& job = findJob(jobId);
  if (job.priority != priority) {
    job.priority = priority;  // tryLease() and jobs() read it on every call: the order follows at once
    if (store_) store_->updateJobPriority(job.id, priority);
    spdlog::info("job {}: priority {}", job.id, priority);
    touch(job);
  }
  return infoOf(job);
}

std::vector<ErrorPoint> Coordinator::errorHistory(const std::string& jobId) const {
  std::lock_guard lock(mutex_);
  return findJob(jobId).history;
}

MetricsSnapshot Coordinator::metricsSnapshot() const {
  MetricsSnapshot s;
  s.jobs = jobs();
  s.workers = workers();
  {
    std::lock_guard lock(mutex_);
    s.leasesActive = leases_.size();
  }
  s.unitsLeased = counters_.unitsLeased;
  s.unitsDone = counters_.unitsDone;
  s.unitsExpired = counters_.unitsExpired;
  s.workersLost = counters_.workersLost;
  s.samples = counters_.samples;
  s.unitBytesReceived = counters_.unitBytes;
  s.assetBytesReceived = counters_.assetBytes;
  s.assetsSent = counters_.assetsSent;
  s.assetUploadsStored = counters_.assetUploadsStored;
  s.assetUploadsPresent = counters_.assetUploadsPresent;
  s.leaseTimeoutSeconds = options_.leaseTimeoutSeconds;
  return s;
}

}  // namespace lensfarm
