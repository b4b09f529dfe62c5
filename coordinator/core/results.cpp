// Coordinator, results: what workers send back for a lease. A unit's result is checked (finite,
// its unit, the lease it quotes, its size), made durable, counted once in the job's JobUnits and
// handed to its Accumulator; the progress that comes back is published to the job, which ends at
// its stop. Also a worker's failure report, and the deadlines (a job stops at its deadline with
// the units summed by then).
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "common/farm/memory_estimate.h"
#include "common/film/work_unit.h"
#include "common/scene/path_limits.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/core/result_checks.h"
#include "coordinator/store/checked_file.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

namespace {
// Appends the job's published estimate to its curve when it changed (requires mutex_).
template <class JobT>
void recordEstimate(JobT& job, double elapsedSeconds) {
  if (!job.progress.estimate.valid) return;
  auto& h = job.progress.history;
  // A job without a target re-estimates a few times a second, not every unit: a point whose
  // estimate did not change would be stale, so only new estimates make points.
  if (!h.empty() && h.back().relativeError == job.progress.estimate.relativeRmse) return;
  if (h.size() >= Coordinator::kMaxErrorPoints) {
    size_t kept = 0;
    for (size_t i = 0; i < h.size(); i += 2) h[kept++] = h[i];
    h.resize(kept);
  }
  h.push_back(ErrorPoint{elapsedSeconds, job.progress.estimate.relativeRmse, job.progress.samplesPerPixelDone});
}
}  // namespace

void Coordinator::enforceDeadlines() {
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  for (auto& [id, jobPtr] : jobs_) {
    Job& job = *jobPtr;
    if (job.progress.deadlinePassed || isTerminal(job.progress.state) ||
        job.definition.settings.timeLimitSeconds <= 0.0 ||
        nowUnix < job.definition.submittedUnixSeconds + job.definition.settings.timeLimitSeconds)
      continue;
    job.progress.deadlinePassed = true;
    const std::optional<Accumulator::Progress> kept = job.film->stopAtDeadline();
    if (!kept) {  // no image yet: the first whole pass is the image
      spdlog::warn("job {}: deadline passed before the first unit was added; stopping after it", job.definition.id);
      continue;
    }
    job.progress.publish(*kept);
    job.progress.stopUnits = kept->foldLimit;
    finish(job, "deadline reached");
    recordEstimate(job, elapsedSecondsOf(job));
    touch(job);
  }
}

bool Coordinator::acceptResult(UnitResult&& result) { return accept(result, &result); }

bool Coordinator::acceptResult(const UnitResult& result) { return accept(result, nullptr); }

// What a unit can produce (docs/farm.md, "Threat model"). Every sample a worker adds is a finite
// float radiance >= 0 (non-finite samples are dropped and counted; a box filter gives each cell
// one sample per pass), so each cell's sum lies in [0, sampleCount x FLT_MAX] and the image's
// mean stays a finite float; one camera path is traced per cell and sample, and lights hit and
// samples dropped are among those paths. Anything else did not come from the renderer.
void Coordinator::checkPlausible(const UnitResult& result, uint64_t cells, uint32_t sampleCount, const AovLayout& aovs,
                                 const SampleMap* map, uint64_t maxRaysPerPath) {
  const std::string what = "result for unit " + std::to_string(result.unitIndex) + " of " + result.jobId;
  // Each channel's range for a cell of n samples (film/aov_layout.h: the beauty's RGB, then the
  // AOVs' sums); an adaptive unit's cells have their block's n.
  const int channels = aovs.channels;
  std::vector<double> lo(static_cast<size_t>(channels)), hi(static_cast<size_t>(channels));
  uint32_t rangeOf = 0;
  const auto rangesFor = [&](uint32_t n) {
    for (int c = 0; c < channels; ++c) aovSumRange(aovs, c, n, lo[size_t(c)], hi[size_t(c)]);
    rangeOf = n;
  };
  rangesFor(sampleCount);
  const std::vector<double>& sums = result.buffer.sums;
  const size_t stride = size_t(channels);
  const size_t whole = sums.size() / stride;  // never reads past the buffer, whatever its size
  const int width = std::max(1, result.buffer.width);
  for (size_t cell = 0; cell < whole; ++cell) {  // cell by cell: no division per sum
    const uint32_t n = map ? map->countAt(int(cell % size_t(width)), int(cell / size_t(width))) : sampleCount;
    if (n != rangeOf) rangesFor(n);
    for (size_t c = 0; c < stride; ++c) {
      const double v = sums[cell * stride + c];
      if (!(v >= lo[c] && v <= hi[c]))  // (false for NaN too)
        throw FarmError(FarmError::Kind::kInvalidArgument,
                        what + " holds " + (std::isfinite(v) ? std::to_string(v) : std::string("a non-finite sum")) +
                            " at cell " + std::to_string(cell) + " sum " + std::to_string(c) + ": a unit of " +
                            std::to_string(n) + " samples sums it to a value in [" + std::to_string(lo[c]) + ", " +
                            std::to_string(hi[c]) + "]");
    }
  }
  const uint64_t paths = map ? map->totalSamples(result.buffer.width, result.buffer.height) : cells * sampleCount;
  const PathStats& s = result.stats;
  if (s.paths != paths)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    what + " counts " + std::to_string(s.paths) + " paths; the unit traces " + std::to_string(paths));
  if (s.lightHits > paths || s.dropped > paths || s.rays / maxRaysPerPath > paths)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    what + " has counters the unit cannot produce (rays " + std::to_string(s.rays) + ", light hits " +
                        std::to_string(s.lightHits) + ", dropped " + std::to_string(s.dropped) + " for " +
                        std::to_string(paths) + " paths)");
  if (!(result.renderSeconds >= 0.0 && result.renderSeconds < 1e9))
    throw FarmError(FarmError::Kind::kInvalidArgument, what + " has a render time that is not a time");
}

void Coordinator::admitUpload(const std::string& workerId, uint64_t leaseId, const std::string& jobId, uint64_t unit,
                              int width, int height, int channels) const {
  MutexLock lock(mutex_);
  const Job& job = findJob(jobId);
  checkUnitExists(job, unit);
  if (job.progress.units.isReceived(unit) || job.progress.units.isRecording(unit))
    return;  // a late duplicate: ignored by accept
  checkLeaseHeld(leases_, leaseId, workerId, jobId, unit);
  checkRegion(job, unit, width, height);
  if (channels != job.definition.layout.channels)
    throw FarmError(FarmError::Kind::kInvalidArgument, "result for unit " + std::to_string(unit) + " of " +
                                                           job.definition.id + " carries " + std::to_string(channels) +
                                                           " sums a cell; the job's AOVs (" +
                                                           aovListText(AovLayout(job.definition.settings.aovs).set) +
                                                           ") make " + std::to_string(job.definition.layout.channels));
}

// A result's way in, in four steps: what the unit can produce (outside the lock), the lease and
// the shape (admit), durable (record), counted (count), then summed by the film and published.
bool Coordinator::accept(const UnitResult& result, UnitResult* owned) {
  counters_.unitBytes += result.buffer.sums.size() * sizeof(double);
  checkProducible(result);
  Admission a = admit(result);
  if (a.duplicate) return false;
  if (a.auditLease) return acceptAudit(result);
  // An audited unit's sums, copied before the film takes them (outside the lock).
  AuditBook::Sums kept;
  if (a.audited) kept = std::make_shared<const std::vector<double>>(result.buffer.sums);
  record(result, a);
  if (!count(result, a, std::move(kept))) return true;  // to be rendered again after a rewind
  sumAndPublish(result, owned, a);
  return true;
}

void Coordinator::checkProducible(const UnitResult& result) {
  // What the unit can produce, checked outside the coordinator's lock (it reads every cell of a
  // frame: leases and heartbeats must not wait for it). A job's settings never change.
  PixelRegion region;
  uint32_t sampleCount = 0;
  AovLayout aovs;
  uint64_t raysPerPath = 1;
  std::shared_ptr<const SampleMap> map;
  {
    MutexLock lock(mutex_);
    const Job& found = findJob(result.jobId);
    if (result.unitIndex < found.progress.units.total()) {
      bool ready = true;
      sampleCount = found.definition.layout.unit(result.unitIndex).sampleCount;
      region = found.definition.layout.regionOf(result.unitIndex);
      aovs = AovLayout(found.definition.settings.aovs);
      raysPerPath = maxRaysPerPath(found.definition.settings);
      if (found.film && found.definition.layout.adaptive()) map = found.film->samplesOf(result.unitIndex, &ready);
      if (!ready) sampleCount = 0;  // not leased yet: refused below (no lease covers it)
    }
  }
  // Only a buffer of the region's shape is read here; any other is refused by the size checks below.
  const uint64_t cells = uint64_t(region.width) * uint64_t(region.height);
  if (sampleCount > 0 && result.buffer.width == region.width && result.buffer.height == region.height &&
      result.buffer.sums.size() == cells * uint64_t(aovs.channels))
    checkPlausible(result, cells, sampleCount, aovs, map.get(), raysPerPath);
}

Coordinator::Admission Coordinator::admit(const UnitResult& result) {
  Admission a;
  MutexLock lock(mutex_);
  Job* job = a.job = &findJob(result.jobId);
  a.pin = JobPin(*this, *job);
  checkUnitExists(*job, result.unitIndex);
  const LeaseTable::Lease* lease = leases_.find(result.leaseId);
  a.auditLease = lease && lease->audit && lease->workerId == result.workerId;
  // A late duplicate of a unit already counted (or being counted) is ignored.
  if (!a.auditLease &&
      (job->progress.units.isReceived(result.unitIndex) || job->progress.units.isRecording(result.unitIndex))) {
    a.duplicate = true;
    return a;
  }
  checkLeaseHeld(leases_, result.leaseId, result.workerId, result.jobId, result.unitIndex);
  // Every unit of a job is traced with its kernel (Lease.kernel), or the image would mix bits.
  if (!result.kernel.empty() && !job->kernel.empty() && result.kernel != job->kernel)
    throw FarmError(FarmError::Kind::kFailedPrecondition,
                    "result for unit " + std::to_string(result.unitIndex) + " of " + result.jobId +
                        " was rendered with traversal kernel \"" + logText(result.kernel.substr(0, 32)) +
                        "\"; the job's is " + job->kernel + " (Lease.kernel)");
  if (!a.auditLease) {
    checkRegion(*job, result.unitIndex, result.buffer.width, result.buffer.height);
    checkSumCount(*job, result.unitIndex, result.buffer.sums.size());
    Worker& worker = findWorker(result.workerId);
    a.workerName = worker.info.name.empty() ? worker.id : worker.info.name;
    a.build = (worker.info.build.empty() ? std::string("build not said") : worker.info.build) + " (" +
              (result.kernel.empty() ? std::string("kernel not said") : result.kernel) + ")";
    leases_.erase(result.leaseId);
    leases_.eraseOthersOf(result.jobId, result.unitIndex, result.leaseId);  // a backup's, or the straggler's
    job->progress.units.beginRecording(result.unitIndex);
    a.generation = job->audit.generation;
    a.audited = chooseForAudit(*job, worker);
  }
  return a;
}

// Durable before acknowledged: the unit's sums and ledger row, outside the coordinator's lock.
void Coordinator::record(const UnitResult& result, const Admission& a) {
  if (store_) {
    try {
      store_->recordUnit(a.job->definition.id,
                         StateStore::LedgerEntry{result.unitIndex, a.workerName, result.stats, a.build},
                         result.buffer.sums);
    } catch (const std::exception& e) {
      MutexLock lock(mutex_);
      a.job->progress.units.endRecording(result.unitIndex);
      if (!isTerminal(a.job->progress.state)) a.job->progress.units.requeue(result.unitIndex);
      if (const auto* storage = dynamic_cast<const StorageError*>(&e)) {
        storageFailed(*storage);
        // The worker is told why (never where: the state dir's path is the coordinator's own).
        throw FarmError(FarmError::Kind::kResourceExhausted,
                        "UploadResult: the coordinator cannot store results now (" +
                            std::string(std::strerror(storage->code())) + "); the unit is leased again when it can");
      }
      spdlog::error("cannot record unit {} of {}: {}", result.unitIndex, a.job->definition.id, e.what());
      throw;
    }
  }
}

bool Coordinator::count(const UnitResult& result, const Admission& a, AuditBook::Sums kept) {
  MutexLock lock(mutex_);
  a.job->progress.units.endRecording(result.unitIndex);
  const Worker* from = workers_.known(result.workerId);
  if (a.job->audit.generation != a.generation || (from && from->quarantined)) {
    // The audit rewound the film, or quarantined this worker, meanwhile (auditing.cpp): this
    // unit is rendered again.
    if (store_) store_->forgetUnits(a.job->definition.id, result.unitIndex, {}, result.unitIndex + 1);
    // (The rewind made it pending again if it is at or past the next fresh unit.)
    if (!isTerminal(a.job->progress.state) && !a.job->progress.units.isReceived(result.unitIndex) &&
        result.unitIndex < a.job->progress.units.nextFresh())
      a.job->progress.units.requeue(result.unitIndex);
    changed_.notify_all();
    return false;
  }
  a.job->progress.units.markReceived(result.unitIndex);
  const uint64_t seq = nextAcceptance_++;
  if (result.unitIndex >= a.job->audit.trustedUnits)
    a.job->audit.provenance[result.unitIndex] = JobAudit::Provenance{result.workerId, seq};
  if (kept) {
    // Film copies to rewind to from the job's first audit on: a job no one audits keeps none.
    a.job->film->keepRewindPoints(rewindPointSpacing(options_.auditFraction), kRewindPoints);
    a.job->audit.audits.open(result.unitIndex, {result.workerId, std::move(kept)}, seq);
  }
  ++counters_.unitsDone;
  counters_.samples += result.stats.paths;
  if (Worker* w = workers_.known(result.workerId)) {
    ++w->unitsDone;
    if (result.renderSeconds > 0.0) w->samplesPerSecond = double(result.stats.paths) / result.renderSeconds;
    if (w->currentUnit == result.unitIndex) w->currentUnit.reset();
  }
  a.job->progress.pathsCounted += result.stats.paths;
  a.job->progress.renderSeconds += std::max(0.0, result.renderSeconds);
  ++a.job->progress.unitsByWorker[a.workerName];
  ++a.job->progress.unitsByBuild[a.build];
  return true;
}

void Coordinator::sumAndPublish(const UnitResult& result, UnitResult* owned, const Admission& a) {
  // Sum outside the coordinator's lock: large buffers must not stall leases and heartbeats.
  const std::optional<Accumulator::Progress> added = a.job->film->add(result, owned, a.generation);
  if (a.job->definition.layout.tiled()) storeCompletedFrames(*a.job);
  MutexLock lock(mutex_);
  if (!added) {
    // The unit is counted but cannot be kept: this job cannot finish; the coordinator and its
    // other jobs go on.
    const std::string what = "coordinator out of memory keeping unit " + std::to_string(result.unitIndex) + " (" +
                             formatBytes(result.buffer.memoryBytes()) + ") until the units before it arrive";
    spdlog::error("job {}: {}", a.job->definition.id, what);
    if (!isTerminal(a.job->progress.state)) {
      a.job->progress.error = what;
      end(*a.job, JobState::kFailed);
      touch(*a.job);
    }
    throw FarmError(FarmError::Kind::kResourceExhausted, a.job->definition.id + ": " + what);
  }
  if (added->units > a.job->progress.unitsAdded && a.job->audit.generation == a.generation) {
    a.job->progress.publish(*added);
    recordEstimate(*a.job, elapsedSecondsOf(*a.job));
    if (!added->stopReason.empty() && a.job->progress.state == JobState::kRunning && !a.job->audit.stopAwaitingAudits) {
      if (added->foldLimit < a.job->progress.units.total()) a.job->progress.stopUnits = added->foldLimit;
      if (a.job->audit.audits.empty()) {
        finish(*a.job, added->stopReason);
      } else {
        // The image is complete unless an audit finds a wrong worker: no more units, and the job
        // ends when its audits settle (settleWaitingJobs).
        a.job->audit.stopAwaitingAudits = added->stopReason;
        a.job->audit.awaitingSince = Clock::now();
        a.job->progress.units.clearPending();
        leases_.eraseUnitsOf(a.job->definition.id);
        settleWaitingJobs();
      }
    }
    touch(*a.job);
  }
}

void Coordinator::reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                                const std::string& error) {
  MutexLock lock(mutex_);
  Worker& worker = findWorker(workerId);
  const LeaseTable::Lease* lease = leases_.find(leaseId);
  if (!lease || lease->workerId != workerId)
    throw FarmError(FarmError::Kind::kFailedPrecondition,
                    "ReportFailure: lease " + std::to_string(leaseId) + " is not held by " + workerId);
  if (lease->jobId != jobId)
    throw FarmError(FarmError::Kind::kFailedPrecondition,
                    "ReportFailure: lease " + std::to_string(leaseId) + " is for " + lease->jobId + ", not " + jobId);
  Job& job = findJob(jobId);
  const uint64_t unit = lease->unit;
  const bool audit = lease->audit;
  leases_.erase(leaseId);
  if (worker.currentUnit == unit) worker.currentUnit.reset();
  worker.currentJobId.clear();
  if (isTerminal(job.progress.state)) return;
  if (audit) {  // the counted result stands; another worker may render it
    job.audit.audits.release(unit, workerId);
    changed_.notify_all();
    return;
  }
  recordFailure(job, worker, unit, error);
}

void Coordinator::recordFailure(Job& job, Worker& worker, uint64_t unit, const std::string& error) {
  ++worker.failures;
  const std::string reason = worker.label() + ": " + error;
  spdlog::warn("job {}: unit {} failed on {}", job.definition.id, unit, logText(reason));
  const JobPolicy& policy = job.definition.policy;  // its own limits, else the coordinator's
  const uint32_t maxUnitFailures = policy.maxUnitFailures.value_or(options_.maxUnitFailures);
  const size_t failedOn =
      job.failures.record(unit, worker.id, reason, policy.maxWorkerFailures.value_or(options_.maxFailuresPerWorker));
  // The job fails (or pauses, by its policy) when the unit failed on enough workers, or no live
  // worker may take it.
  bool anyoneLeft = false;
  for (const auto& [id, w] : workers_) anyoneLeft |= !w->gone && !job.failures.blocks(id);
  const bool requeue = !job.progress.units.isReceived(unit) && !job.progress.units.isRecording(unit) &&
                       leases_.unitLeases(job.definition.id, unit).empty();  // (a backup still renders it)
  if (failedOn >= maxUnitFailures || !anyoneLeft) {
    const std::string reasons = job.failures.reasons();
    const std::string why = failedOn >= maxUnitFailures ? "unit " + std::to_string(unit) + " failed on " +
                                                              std::to_string(failedOn) + " workers: " + reasons
                                                        : "no worker left that has not failed it: " + reasons;
    if (policy.onFailure == OnFailure::kPause) {
      if (requeue) job.progress.units.requeue(unit);  // kept for when it is resumed
      job.paused = true;
      job.addEvent("paused by its failure policy: " + why +
                   "; resume it (lensfarm resume) to forget its failures and try again, or cancel it");
      persistState(job);
    } else {
      job.progress.error = why;
      end(job, JobState::kFailed);
      spdlog::error("job {}: failed: {}", job.definition.id, logText(job.progress.error));
    }
  } else if (requeue) {
    job.progress.units.requeue(unit);  // for another worker (or this one, until it is blocklisted)
    changed_.notify_all();
  }
  touch(job);
}

}  // namespace lensfarm
