// Coordinator, durable state (with a state dir; StateStore in state_store.h does the writing): a
// job's state as it changes, periodic checkpoints of every job's Accumulator, and restore(),
// which rebuilds the job table at start-up from the jobs, the last checkpoints and the ledger of
// accepted units, so a resumed job's image is bitwise the uninterrupted one.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>

#include "common/farm/job_scene.h"
#include "common/farm/memory_estimate.h"
#include "common/scene/scene_loader.h"
#include "common/util/log_text.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/store/checked_file.h"
#include "coordinator/store/frame_store.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

void Coordinator::persistState(const Job& job) {
  if (!store_) return;
  try {
    store_->updateJobState(job.definition.id, jobStateName(job.progress.state), job.progress.error,
                           job.progress.stopUnits, job.progress.stopReason, job.retention.endedUnixSeconds);
    if (!job.kernel.empty()) store_->updateJobKernel(job.definition.id, job.kernel);
    store_->updateJobSchedule(job.definition.id, job.paused, job.approved, job.released);
  } catch (const StorageError& e) {
    storageFailed(e);  // kept in memory, written again when the state dir takes writes (probeStorage)
  }
}

void Coordinator::checkpointLoop() {
  MutexLock lock(mutex_);
  while (!stopping_) {
    const double wait = storageStall_ ? std::min(kStorageProbeSeconds, options_.checkpointEverySeconds)
                                      : options_.checkpointEverySeconds;
    lock.waitFor(checkpointWake_, std::chrono::duration<double>(wait));
    if (stopping_) break;
    const bool stalled = storageStall_.has_value();
    lock.unlock();
    try {
      if (stalled)
        probeStorage();
      else
        checkpoint();
    } catch (const StorageError& e) {
      MutexLock relock(mutex_);
      storageFailed(e);
    } catch (const std::exception& e) {
      spdlog::error("checkpoint failed (the ledger still holds every unit): {}", e.what());
    }
    lock.lock();
  }
}

void Coordinator::storageFailed(const StorageError& e) {
  ++counters_.stateWriteFailures;
  if (storageStall_) return;
  std::error_code ec;
  const std::filesystem::path relative = std::filesystem::relative(e.file(), options_.stateDir, ec);
  storageStall_ = StorageStall{(ec ? e.file() : relative).string() + ": " + std::strerror(e.code()), Clock::now()};
  spdlog::error("the state dir refused a write ({}): no unit is leased until it takes writes again", e.what());
  for (auto& [id, job] : jobs_)
    if (!isTerminal(job->progress.state)) touch(*job);  // watchers see the stalled reason
}

// A write of the size of a large unit's file, in the state dir: when it goes through, leasing
// resumes.
void Coordinator::probeStorage() {
  const std::filesystem::path probe = std::filesystem::path(options_.stateDir) / "write-probe";
  writeCheckedFile(probe, {std::string(size_t(16) << 20, '\0')});  // throws StorageError while it cannot
  std::error_code ignored;
  std::filesystem::remove(probe, ignored);
  MutexLock lock(mutex_);
  if (!storageStall_) return;
  spdlog::info("the state dir takes writes again after {:.0f} s: leasing resumes",
               std::chrono::duration<double>(Clock::now() - storageStall_->since).count());
  storageStall_.reset();
  for (auto& [id, job] : jobs_) {
    persistState(*job);  // the states a refused write left in memory only
    if (!isTerminal(job->progress.state)) touch(*job);
  }
}

uint64_t Coordinator::checkpoint() {
  if (!store_) return 0;
  // Each job pinned (lifecycle.cpp): not deleted or archived while its sensor is saved.
  std::vector<std::pair<Job*, JobPin>> all;
  {
    MutexLock lock(mutex_);
    for (auto& [id, job] : jobs_)
      if (job->film && !job->retention.archiving && !job->retention.deleting)
        all.emplace_back(job.get(), JobPin(*this, *job));
  }
  uint64_t bytes = 0;
  for (auto& [job, pin] : all) {
    std::lock_guard checkpointLock(checkpointMutex_);  // a rewind (auditing.cpp) rewrites it
    const std::optional<Accumulator::Snapshot> snapshot = job->film->snapshotIfChanged();
    if (!snapshot) continue;
    store_->writeCheckpoint(job->definition.id, snapshot->sensor, snapshot->tracker, snapshot->folded);
    bytes += snapshot->sensor.size();
    job->film->checkpointed(snapshot->folded);
  }
  return bytes;
}

void Coordinator::storeCompletedFrames(Job& job) {
  if (!job.film) return;  // archived
  std::vector<TileFilm::Completed> done = job.film->takeCompletedFrames();
  if (done.empty()) return;
  ImageMetadata metadata;
  {
    MutexLock lock(mutex_);
    metadata = metadataOf(job);
  }
  const uint64_t perFrame = job.definition.layout.unitsPerFrame();
  for (TileFilm::Completed& c : done) {
    // A still's film holds its image, and the ledger's unit files are its durable state (a
    // rewind by the audit may undo some of its tiles): only an animation's frames are stored.
    if (!job.definition.layout.frames) continue;
    ImageMetadata m = metadata;
    m.samplesPerPixel = job.definition.layout.samplesPerPixel;
    m.totalSamples = uint64_t(job.definition.layout.width) * uint64_t(job.definition.layout.height) *
                     job.definition.layout.samplesPerPixel;
    if (job.definition.layout.frames)
      m.extra["frame"] = std::to_string(job.definition.layout.frameNumber(c.frameIndex));
    try {
      frames_->write(job.definition.id, c.frameIndex, *c.image, m);
      // Stored durably: the film lets its image go, and its tiles' sums are no longer needed
      // (their ledger rows stay).
      job.film->frameStored(c.frameIndex);
      if (store_) store_->dropUnitFiles(job.definition.id, c.frameIndex * perFrame, (c.frameIndex + 1) * perFrame);
    } catch (const std::exception& e) {
      // The film still serves the image, and the ledger still holds every tile: a restart stores
      // the frame again.
      spdlog::error("job {}: cannot store frame {}: {}", job.definition.id, c.frameIndex, e.what());
    }
  }
  MutexLock lock(mutex_);
  touch(job);
}

static JobState parseJobState(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kCancelled, JobState::kFailed})
    if (name == jobStateName(s)) return s;
  throw std::runtime_error("unknown job state " + name);
}

std::optional<uint64_t> Coordinator::restoreTiled(Job& job) {
  // An animation's frames stored before the restart count whole; the ledger's other tiles are
  // written again from their unit files, in any order (tile_film.h).
  const JobLayout& layout = job.definition.layout;
  job.film = std::make_unique<Accumulator>(job.definition.settings, layout);
  std::set<uint64_t> stored = frames_->storedFrames(job.definition.id);
  // A damaged frame file is kept aside and its tiles rendered again (their unit files went when
  // the frame was stored, so the ledger's rows for them are dropped as missing).
  for (auto it = stored.begin(); it != stored.end();) {
    if (const std::optional<std::string> damage = frames_->damage(job.definition.id, *it)) {
      const std::filesystem::path aside = store_->setAside(frames_->pathOf(job.definition.id, *it));
      reportRepair(job, "frame file " + frames_->pathOf(job.definition.id, *it).filename().string() + " was " +
                            *damage + "; kept as " + aside.string() + " and its tiles are rendered again");
      it = stored.erase(it);
    } else {
      ++it;
    }
  }
  for (uint64_t f : stored)
    if (layout.frames && f < layout.frameCount()) job.film->restoreCompleteFrame(f);
  const auto inStoredFrame = [&](uint64_t unit) { return stored.count(layout.frameIndexOf(unit)) > 0; };
  std::optional<uint64_t> highest = replayStoredUnits(job, [&](uint64_t unit) { return !inStoredFrame(unit); });
  // A stored frame counts whole even where the ledger lost its rows.
  for (uint64_t unit = 0; unit < job.progress.units.total(); ++unit)
    if (inStoredFrame(unit) && !job.progress.units.isReceived(unit)) {
      job.progress.units.markReceived(unit);
      highest = std::max(highest.value_or(0), unit);
    }
  return highest;
}

// Counts the units the ledger and the unit files agree on (StateStore::reconcileUnits): those
// folded into the checkpoint or a stored frame by their counters alone, the others replayed into
// the film from their sums. Returns the highest unit counted.
std::optional<uint64_t> Coordinator::replayStoredUnits(Job& job, const std::function<bool(uint64_t)>& fileExpected) {
  const JobLayout& layout = job.definition.layout;
  StateStore::Reconciled units =
      store_->reconcileUnits(job.definition.id, fileExpected, [&](uint64_t unit) { return layout.sumsOf(unit); });
  for (const std::string& repair : units.repairs) reportRepair(job, repair);
  std::optional<uint64_t> highest;
  for (StateStore::StoredUnit& u : units.units) {
    const StateStore::LedgerEntry& entry = u.entry;
    if (entry.unit >= job.progress.units.total()) continue;
    job.progress.units.markReceived(entry.unit);
    ++job.progress.unitsByWorker[entry.worker];
    if (!entry.build.empty()) ++job.progress.unitsByBuild[entry.build];
    highest = std::max(highest.value_or(0), entry.unit);
    if (!u.sums) {
      job.film->restoreFolded(entry.stats);
      continue;
    }
    UnitResult r;
    r.jobId = job.definition.id;
    r.unitIndex = entry.unit;
    r.stats = entry.stats;
    if (layout.tiled()) {  // a tile, written again in any order (tile_film.h)
      r.workerId = entry.worker;
      const PixelRegion region = layout.regionOf(entry.unit);
      r.buffer.width = region.width;
      r.buffer.height = region.height;
    } else {  // the whole frame; the counts are the coordinator's (drainInOrder)
      r.buffer.width = job.definition.settings.width;
      r.buffer.height = job.definition.settings.height;
      r.buffer.channels = layout.channels;
    }
    r.buffer.sums = std::move(*u.sums);
    job.film->restoreWaiting(std::move(r));
  }
  return highest;
}

// A repair of the state dir (state_store.h): an error in the log and an event of the job.
void Coordinator::reportRepair(Job& job, const std::string& repair) {
  spdlog::error("restore {}: {}", job.definition.id, repair);
  job.addEvent("state dir repaired: " + repair);
}

void Coordinator::restore() {
  // Nothing else runs yet (the constructor calls this before any thread starts); the lock keeps
  // the rules the same as everywhere else. The frames are stored after it, as they take it.
  std::vector<Job*> tiled;
  restoreJobs(tiled);
  for (Job* job : tiled) storeCompletedFrames(*job);
}

// A stored job's record and its scene (loaded with its overrides, its assets from the store).
std::unique_ptr<Coordinator::Job> Coordinator::jobFromRow(const StateStore::StoredJob& stored, Scene* scene) {
  auto job = std::make_unique<Job>();
  job->definition.id = stored.id;
  job->definition.spec = stored.spec;
  job->priority = stored.priority;
  job->definition.sequence = stored.sequence;
  job->definition.submittedUnixSeconds = stored.submittedUnixSeconds;
  job->progress.state = parseJobState(stored.state);
  job->progress.error = stored.error;
  job->progress.stopUnits = stored.stopUnits;
  job->progress.stopReason = stored.stopReason;
  job->definition.owner = stored.owner;
  job->kernel = !stored.kernel.empty()         ? stored.kernel
                : stored.spec.overrides.kernel ? std::string(kernelName(*stored.spec.overrides.kernel))
                                               : std::string();
  job->retention.endedUnixSeconds = stored.endedUnixSeconds;
  std::string damage;
  job->definition.policy = policyFromJson(stored.policy, &damage);
  if (!damage.empty()) job->addEvent(damage);
  job->paused = stored.paused;
  job->approved = stored.approved;
  job->released = stored.released;
  const AssetReader reader = [&](const std::string& path) -> std::optional<std::string> {
    auto it = job->definition.spec.assets.find(path);
    if (it == job->definition.spec.assets.end()) return std::nullopt;
    const std::shared_ptr<const std::string> bytes = assets_.find(it->second);
    if (!bytes) return std::nullopt;
    return *bytes;
  };
  *scene = jobScene(job->definition.spec, reader);
  job->setScene(*scene);
  return job;
}

// An unarchived job's film: its checkpoint, then its ledger's units replayed in order (a tiled
// job's tiles from its stored frames); its stop applied as before the restart. Returns the units
// the checkpoint held.
uint64_t Coordinator::restoreFilm(Job& job, const Scene& scene, const StateStore::StoredJob& stored,
                                  Clock::time_point now, double nowUnix) {
  std::optional<uint64_t> highest;
  uint64_t folded = 0;
  // Accepted before the restart: held again whatever the budget says now (it may be smaller).
  const MemoryEstimate estimate = coordinatorJobMemory(scene.render, options_.maxBytesAhead, true,
                                                       options_.auditFraction > 0.0 ? kRewindPoints : 0);
  job.memory = memory_->force(estimate.total() - estimate.items.back().bytes, job.definition.id);
  if (job.definition.layout.tiled()) {
    highest = restoreTiled(job);
  } else {
    // The checkpoint holds units [0, folded); the ledger and the unit files list every accepted unit.
    std::string damage;
    const auto checkpoint = store_->loadCheckpoint(job.definition.id, &damage);
    if (!damage.empty()) reportRepair(job, damage + "; the units it held are rendered again");
    if (checkpoint) {
      Sensor sensor = Sensor::deserialize(checkpoint->sensorBytes);
      job.film = std::make_unique<Accumulator>(scene.render, job.definition.layout, std::move(sensor),
                                               checkpoint->trackerBytes, checkpoint->foldedUnits);
      folded = checkpoint->foldedUnits;
    } else {
      job.film = std::make_unique<Accumulator>(scene.render, job.definition.layout);
    }
  }
  if (stored.stopUnits) job.film->limitTo(*stored.stopUnits);
  if (!job.definition.layout.tiled()) {
    highest = replayStoredUnits(job, [&](uint64_t unit) { return unit >= folded; });
    // The checkpoint holds its units whether or not the ledger kept their rows.
    std::vector<uint64_t> unlisted;
    for (uint64_t unit = 0; unit < folded; ++unit)
      if (!job.progress.units.isReceived(unit)) {
        job.progress.units.markReceived(unit);
        unlisted.push_back(unit);
      }
    if (!unlisted.empty()) {
      highest = std::max(highest.value_or(0), folded - 1);
      reportRepair(job, std::to_string(unlisted.size()) +
                            " unit(s) held by the checkpoint had no ledger row: counted (their path and ray "
                            "counters are not known)");
    }
  }
  job.film->drain();
  // Units leased before the restart and never acknowledged go back to the queue.
  job.progress.units.resumeAfter(highest);
  if (isTerminal(job.progress.state)) job.progress.units.clearPending();
  const Accumulator::Progress progress = job.film->estimateNow();
  job.progress.publish(progress);
  if (highest) job.progress.started = now;  // elapsed time restarts with the coordinator (docs/farm.md)
  if (isTerminal(job.progress.state)) job.progress.started = job.progress.finished = now;
  // A job that ended before its end time was stored: retention counts from this start.
  if (isTerminal(job.progress.state) && job.retention.endedUnixSeconds <= 0.0) {
    job.retention.endedUnixSeconds = nowUnix;
    persistState(job);
  }
  if (job.progress.state == JobState::kRunning && !progress.stopReason.empty()) {
    // It reached its stop before the restart (or in the replay): same units, same image.
    job.progress.state = JobState::kDone;
    job.retention.endedUnixSeconds = nowUnix;
    job.progress.stopReason = progress.stopReason;
    if (progress.units < job.progress.units.total()) {
      job.progress.stopUnits = progress.units;
      job.film->limitTo(progress.units);
    }
    job.progress.units.clearPending();
    persistState(job);
  }
  return folded;
}

void Coordinator::restoreJobs(std::vector<Job*>& tiled) {
  MutexLock lock(mutex_);
  assets_.restore(*store_);
  // The database's own repairs and the jobs taken back from their files (state_store.h).
  for (const std::string& repair : store_->openingRepairs()) spdlog::error("restore: {}", repair);
  for (const std::string& repair : store_->recoverJobs()) spdlog::error("restore: {}", repair);
  nextJob_ = std::max(nextJob_, store_->lastJobNumber() + 1);  // a deleted job's id is not reissued
  const auto now = Clock::now();
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const auto restoreJob = [&](StateStore::StoredJob& stored) {
    mutex_.assertHeld();  // called below, under the lock
    Scene scene;
    std::unique_ptr<Job> job = jobFromRow(stored, &scene);
    if (stored.archived) {  // its final image is in the archive (lifecycle.cpp): no film, no ledger
      job->retention.archived = true;
      restoreSummary(*job, stored.summary);
      job->progress.units.clearPending();
      job->progress.started = job->progress.finished = now;
      store_->markArchived(job->definition.id, stored.summary);  // files a crash left behind
      nextJob_ = std::max(nextJob_, uint64_t(std::stoull(job->definition.id.substr(4))) + 1);
      nextSequence_ = std::max(nextSequence_, job->definition.sequence + 1);
      spdlog::info("restored {}: {}, archived", job->definition.id, jobStateName(job->progress.state));
      jobs_[job->definition.id] = std::move(job);
      return;
    }

    const uint64_t folded = restoreFilm(*job, scene, stored, now, nowUnix);
    nextJob_ = std::max(nextJob_, uint64_t(std::stoull(job->definition.id.substr(4))) + 1);
    nextSequence_ = std::max(nextSequence_, job->definition.sequence + 1);
    spdlog::info("restored {}: {}, {} of {} units ({} from the checkpoint)", job->definition.id,
                 jobStateName(job->progress.state), job->progress.unitsAdded, job->progress.units.total(), folded);
    jobs_[job->definition.id] = std::move(job);
  };
  for (StateStore::StoredJob& stored : store_->loadJobs()) {
    // One job that cannot come back (out of memory for its buffers, files no repair explains)
    // stays out, and in the state dir, not the others.
    std::string failure;
    try {
      restoreJob(stored);
    } catch (const std::bad_alloc&) {
      failure = "out of memory for its buffers";
    } catch (const std::exception& e) {
      failure = e.what();
    }
    if (failure.empty()) continue;
    jobs_.erase(stored.id);
    nextJob_ = std::max(nextJob_, uint64_t(std::stoull(stored.id.substr(4))) + 1);
    nextSequence_ = std::max(nextSequence_, stored.sequence + 1);
    spdlog::error("cannot restore {}: {}; it stays in the state directory", stored.id, logText(failure));
  }
  // Frames the replay completed (stored only in part before the restart) are stored after this.
  for (auto& [id, job] : jobs_)
    if (job->definition.layout.tiled()) tiled.push_back(job.get());
}

}  // namespace lensfarm
