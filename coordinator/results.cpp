// Coordinator, results: what workers send back for a lease. A unit's result is checked (finite,
// its unit, the lease it quotes, its size), made durable, counted once in the job's JobUnits and
// handed to its Accumulator; the progress that comes back is published to the job, which ends at
// its stop. Also a worker's failure report, and the deadlines (a job stops at its deadline with
// the units summed by then).
#include <spdlog/spdlog.h>

#include <cmath>

#include "coordinator.h"
#include "coordinator_records.h"
#include "render/memory_estimate.h"
#include "state_store.h"
#include "util/error.h"

namespace lensfarm {

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

void Coordinator::enforceDeadlines() {
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  for (auto& [id, jobPtr] : jobs_) {
    Job& job = *jobPtr;
    if (job.deadlinePassed || isTerminal(job.state) || job.settings.timeLimitSeconds <= 0.0 ||
        nowUnix < job.submittedUnixSeconds + job.settings.timeLimitSeconds)
      continue;
    job.deadlinePassed = true;
    const std::optional<Accumulator::Progress> kept = job.film->stopAtDeadline();
    if (!kept) {  // no image yet: the first whole pass is the image
      spdlog::warn("job {}: deadline passed before the first unit was added; stopping after it", job.id);
      continue;
    }
    job.publish(*kept);
    job.stopUnits = kept->foldLimit;
    finish(job, "deadline reached");
    recordEstimate(job, elapsedSecondsOf(job));
    touch(job);
  }
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
    if (result.unitIndex >= job->units.total())
      throw FarmError(FarmError::Kind::kInvalidArgument,
                      "job " + job->id + " has no unit " + std::to_string(result.unitIndex));
    // A late duplicate of a unit already counted (or being counted) is ignored.
    if (job->units.isReceived(result.unitIndex) || job->units.isRecording(result.unitIndex)) return false;
    if (!leases_.covers(result.leaseId, result.workerId, result.jobId, result.unitIndex))
      throw FarmError(FarmError::Kind::kFailedPrecondition, "lease " + std::to_string(result.leaseId) + " for unit " +
                                                                std::to_string(result.unitIndex) + " of " +
                                                                result.jobId + " is not held by " + result.workerId);
    const int w = job->settings.width, h = job->settings.height;
    if (result.buffer.width != w || result.buffer.height != h || result.buffer.sums.size() != size_t(w) * size_t(h) * 3)
      throw FarmError(FarmError::Kind::kInvalidArgument, "result for " + job->id + " has the wrong size");
    Worker& worker = findWorker(result.workerId);
    workerName = worker.info.name.empty() ? worker.id : worker.info.name;
    leases_.erase(result.leaseId);
    job->units.beginRecording(result.unitIndex);
  }

  // Durable before acknowledged: the unit's sums and ledger row, outside the coordinator's lock.
  if (store_) {
    try {
      store_->recordUnit(job->id, StateStore::LedgerEntry{result.unitIndex, workerName, result.stats},
                         result.buffer.sums);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      job->units.endRecording(result.unitIndex);
      if (!isTerminal(job->state)) job->units.requeue(result.unitIndex);
      spdlog::error("cannot record unit {} of {}: {}", result.unitIndex, job->id, e.what());
      throw;
    }
  }
  {
    std::lock_guard lock(mutex_);
    job->units.endRecording(result.unitIndex);
    job->units.markReceived(result.unitIndex);
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
  const std::optional<Accumulator::Progress> added = job->film->add(result, owned);

  std::lock_guard lock(mutex_);
  if (!added) {
    // The unit is counted but cannot be kept: this job cannot finish; the coordinator and its
    // other jobs go on.
    const std::string what = "coordinator out of memory keeping unit " + std::to_string(result.unitIndex) + " (" +
                             formatBytes(result.buffer.memoryBytes()) + ") until the units before it arrive";
    spdlog::error("job {}: {}", job->id, what);
    if (!isTerminal(job->state)) {
      job->error = what;
      end(*job, JobState::kFailed);
      touch(*job);
    }
    throw FarmError(FarmError::Kind::kResourceExhausted, job->id + ": " + what);
  }
  if (added->units > job->unitsAdded) {
    job->publish(*added);
    recordEstimate(*job, elapsedSecondsOf(*job));
    if (!added->stopReason.empty() && job->state == JobState::kRunning) {
      if (added->foldLimit < job->units.total()) job->stopUnits = added->foldLimit;
      finish(*job, added->stopReason);
    }
    touch(*job);
  }
  return true;
}

void Coordinator::reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId,
                                const std::string& error) {
  std::lock_guard lock(mutex_);
  Job& job = findJob(jobId);
  if (!leases_.heldBy(leaseId, workerId)) return;  // stale report
  if (!isTerminal(job.state)) {
    job.error = workerId + ": " + error;
    end(job, JobState::kFailed);
    spdlog::error("job {}: failed on {}: {}", job.id, workerId, error);
    touch(job);
  }
}

}  // namespace lensfarm
