// Coordinator, the scheduler: which unit is leased to which worker (tryLease: the job first by
// priority, then submission, among those whose units fit the worker, a fresh unit only within
// the window ahead of the summed prefix), heartbeats that extend leases, and the ends of leases
// (expiry, a worker's loss or departure, a job's end) that queue their units again. The lease
// records are LeaseTable's (lease_table.h), each job's queue is its JobUnits (job_units.h).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "common/farm/memory_estimate.h"
#include "common/util/log_text.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/store/checked_file.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

Coordinator::Clock::time_point Coordinator::leaseDeadline(Clock::time_point now) const {
  return now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.leaseTimeoutSeconds));
}

Coordinator::Clock::time_point Coordinator::longestLeaseEnd(const Job& job, Clock::time_point now) const {
  double seconds = std::max(options_.maxLeaseSeconds, 1e-3);
  if (job.definition.policy.unitTimeLimitSeconds)
    seconds = std::min(seconds, *job.definition.policy.unitTimeLimitSeconds);
  return now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

void Coordinator::reapExpiredLeases(Clock::time_point now) {
  for (const auto& [leaseId, lease] : leases_.takeExpired(now)) {
    Job& job = findJob(lease.jobId);
    const std::optional<double> limit = job.definition.policy.unitTimeLimitSeconds;
    if (limit && !lease.audit && lease.deadline >= lease.longestEnd && !isTerminal(job.progress.state) &&
        !job.progress.units.isReceived(lease.unit) && !job.progress.units.isRecording(lease.unit)) {
      // Its unit time limit passed (a worker that heartbeats but never finishes): a failure of that
      // worker, by the job's limits; the unit goes back to the queue.
      ++counters_.unitsExpired;
      if (Worker* w = workers_.known(lease.workerId)) {
        if (w->currentJobId == job.definition.id) w->currentJobId.clear();
        char text[32];
        std::snprintf(text, sizeof text, "%.3g s", *limit);
        recordFailure(job, *w, lease.unit,
                      "unit " + std::to_string(lease.unit) + " took longer than its time limit of " + text);
      } else if (leases_.unitLeases(job.definition.id, lease.unit).empty()) {
        job.progress.units.requeue(lease.unit);
      }
      changed_.notify_all();
      continue;
    }
    spdlog::warn("job {}: lease {} of unit {} held by {} lapsed; the unit goes back to the queue", job.definition.id,
                 leaseId, lease.unit, lease.workerId);
    if (lease.audit) job.audit.audits.release(lease.unit, lease.workerId);
    // (A unit whose backup is still leased is not queued again: the backup renders it.)
    if (!lease.audit && !isTerminal(job.progress.state) && !job.progress.units.isReceived(lease.unit) &&
        leases_.unitLeases(job.definition.id, lease.unit).empty())
      job.progress.units.requeue(lease.unit);
    ++counters_.unitsExpired;
    if (Worker* w = workers_.known(lease.workerId); w && w->currentJobId == job.definition.id) w->currentJobId.clear();
    changed_.notify_all();
  }
  enforceDeadlines();
  settleWaitingJobs();
  updateDependencies();
  forgetSilentWorkers(now);
}

std::optional<LeaseGrant> Coordinator::tryLease(Worker& worker, Clock::time_point now) {
  if (worker.quarantined) return std::nullopt;  // auditing.cpp: it is leased nothing more
  if (storageStall_) return std::nullopt;       // a result could not be kept now (persistence.cpp)
  // Units under audit first: they hold back their jobs' ends, and are few.
  if (auto grant = tryAuditLease(worker, now)) return grant;
  std::vector<Job*> candidates;
  for (auto& [id, job] : jobs_) {
    if (isTerminal(job->progress.state) || !job->progress.units.hasPending()) continue;
    if (!job->takes(worker.info)) continue;          // its units are for a worker with more memory, or another kernel
    if (job->failures.blocks(worker.id)) continue;   // it failed this job too often (reportFailure)
    if (!policyAllows(*job, worker, now)) continue;  // paused, waiting, tags, cap (scheduling.cpp)
    if (!job->progress.units.hasReturned() &&
        !job->definition.layout.tiled()) {  // a fresh pass: only within the window ahead of the summed prefix
      const uint64_t window =
          unitsAheadWindow(job->definition.settings.width, job->definition.settings.height, options_.maxBytesAhead);
      if (job->progress.units.nextFresh() >= job->progress.unitsAdded + window) continue;
    }
    // An adaptive round is leased once the film before it is summed (farm/job_layout.h), a unit
    // queued again too (after a restart, one above a gap whose round is not allocated yet).
    if (job->definition.layout.adaptive() && job->film && !job->film->leasable(job->progress.units.peekPending()))
      continue;
    candidates.push_back(job.get());
  }
  // The order among them (scheduling.cpp): priority, urgency by deadline, fair share.
  std::map<int, std::set<std::string>> owners;  // by priority: the owners with work
  for (const Job* job : candidates) owners[job->priority].insert(job->definition.owner);
  Job* best = nullptr;
  bool bestUrgent = false;
  for (Job* job : candidates) {
    const bool isUrgent = urgent(*job, owners[job->priority].size(), now);
    if (!best || leasedBefore(*job, isUrgent, *best, bestUrgent)) best = job, bestUrgent = isUrgent;
  }
  if (!best) return tryBackupLease(worker, now);
  Job& job = *best;
  if (job.kernel.empty()) pinKernel(job, worker);
  const uint64_t unit = job.progress.units.takePending();
  chargeShare(job, unit);
  const auto longest = longestLeaseEnd(job, now);
  const uint64_t leaseId = leases_.grant(worker.id, job.definition.id, unit, leaseDeadline(now), longest);
  ++counters_.unitsLeased;
  if (!job.progress.started) job.progress.started = now;
  if (job.progress.state == JobState::kQueued) {
    job.progress.state = JobState::kRunning;
    persistState(job);
    notify(job, farm_event::kJobStarted, "first unit leased to " + worker.label());
  }
  worker.currentJobId = job.definition.id;
  worker.currentUnit = unit;
  touch(job);
  bool ready = true;
  WorkUnit leased = unitToLease(job, unit, &ready);
  // (the check above leases a round's unit only once it is allocated)
  if (!ready)
    throw std::logic_error("unit " + std::to_string(unit) + " of " + job.definition.id + " leased before its round");
  return grantOf(job, leaseId, std::move(leased));
}

LeaseGrant Coordinator::grantOf(const Job& job, uint64_t leaseId, WorkUnit unit) const {
  LeaseGrant grant{leaseId, job.definition.id, std::move(unit), job.definition.sceneHash, options_.leaseTimeoutSeconds};
  grant.kernel = job.kernel;
  return grant;
}

void Coordinator::pinKernel(Job& job, const Worker& worker) {
  std::vector<std::vector<std::string>> connected;
  std::string runs;  // for the event: what each worker runs
  const auto heardWithin = std::chrono::duration<double>(staleAfterSeconds());
  for (const auto& [id, w] : workers_) {
    if (w->gone || w->quarantined || Clock::now() - w->lastHeartbeat > heardWithin || !job.definition.fitsOn(w->info))
      continue;
    connected.push_back(w->info.kernels);
    if (!w->info.kernels.empty()) {
      std::string list;
      for (const std::string& k : w->info.kernels) list += (list.empty() ? "" : " ") + k;
      runs += (runs.empty() ? "" : ", ") + w->label() + ": " + list;
    }
  }
  job.kernel = commonKernel(connected, worker.info.kernels);
  if (job.kernel.empty()) return;  // no worker said which it runs: each traces with its own
  job.addEvent("traces with Embree's " + job.kernel + " kernel, the widest every connected worker runs (" + runs +
               "): the same bits whichever renders what; a worker without it is not leased this job");
  if (store_) try {
      store_->updateJobKernel(job.definition.id, job.kernel, true);
    } catch (const StorageError& e) {
      storageFailed(e);  // the row is written again with the job's state (persistState)
    }
}

double Coordinator::expectedUnitSeconds(const Job& job, uint64_t unit, const Worker& worker) const {
  if (!(worker.samplesPerSecond > 0.0)) return -1.0;
  const WorkUnit w = job.definition.layout.unit(unit);
  const PixelRegion region = job.definition.layout.regionOf(unit);
  return double(region.width) * double(region.height) * double(w.sampleCount) / worker.samplesPerSecond;
}

std::optional<LeaseGrant> Coordinator::tryBackupLease(Worker& worker, Clock::time_point now) {
  // Stragglers (Dean and Ghemawat, "MapReduce", OSDI 2004, §3.6): a worker with nothing to do
  // renders a unit still leased to a much slower one. Both leases stand; the first result counts
  // and ends the other (admit), the unit is counted once, and the image does not change, as any
  // worker's result for a unit is the same bits. One backup a unit; never an audit.
  Job* bestJob = nullptr;
  const LeaseTable::Lease* straggler = nullptr;
  double bestGain = 0.0;
  for (auto& [id, job] : jobs_) {
    // (Called when no job has a unit for this worker: a job's pending units, if any, are beyond the
    // window ahead of its summed prefix, which a straggler's unit holds back.)
    if (isTerminal(job->progress.state) || job->audit.stopAwaitingAudits || !job->takes(worker.info) ||
        job->failures.blocks(worker.id) || job->paused ||
        !hasAllTags(worker.info.tags, job->definition.policy.requireTags) || (bestJob && bestJob->servedBefore(*job)))
      continue;  // (the first job by service order that has a straggler worth a backup)
    for (const LeaseTable::Lease* lease : leases_.ofJob(job->definition.id)) {
      if (lease->audit || lease->workerId == worker.id ||
          leases_.unitLeases(job->definition.id, lease->unit).size() > 1 ||
          job->progress.units.isRecording(lease->unit) || job->progress.units.isReceived(lease->unit))
        continue;
      const double mine = expectedUnitSeconds(*job, lease->unit, worker);
      if (mine < 0.0) continue;  // this worker's speed is not known yet
      const Worker* holder = workers_.known(lease->workerId);
      const double elapsed = std::chrono::duration<double>(now - lease->granted).count();
      const double theirs = holder ? expectedUnitSeconds(*job, lease->unit, *holder) : -1.0;
      // What the backup saves: the holder's expected time left against this worker's whole unit,
      // with margin. A holder of unknown speed is expected to take as long again as it has so far.
      const double left = theirs >= 0.0 ? theirs - elapsed : elapsed;
      const double gain = left - kBackupMargin * mine;
      if (gain > 0.0 && (bestJob != job.get() || gain > bestGain))
        bestJob = job.get(), straggler = lease, bestGain = gain;
    }
  }
  if (!bestJob) return std::nullopt;
  Job& job = *bestJob;
  const uint64_t unit = straggler->unit;
  const std::string holder = workers_.labelOf(straggler->workerId);
  const double elapsed = std::chrono::duration<double>(now - straggler->granted).count();
  bool ready = true;
  WorkUnit leased = unitToLease(job, unit, &ready);
  if (!ready) return std::nullopt;
  const auto longest = longestLeaseEnd(job, now);
  const uint64_t leaseId = leases_.grant(worker.id, job.definition.id, unit, leaseDeadline(now), longest);
  ++counters_.unitsLeased;
  ++counters_.backupLeases;
  worker.currentJobId = job.definition.id;
  worker.currentUnit = unit;
  job.addEvent("unit " + std::to_string(unit) + ", leased to " + holder + " " + secondsText(elapsed) +
               " ago, also leased to " + worker.label() + " (about " + secondsText(bestGain) +
               " sooner): the first result counts");
  touch(job);
  return grantOf(job, leaseId, std::move(leased));
}

WorkUnit Coordinator::unitToLease(const Job& job, uint64_t unit, bool* ready) const {
  WorkUnit w = job.definition.layout.unit(unit);
  if (ready) *ready = true;
  if (job.definition.layout.adaptive() && job.film) w.samples = job.film->samplesOf(unit, ready);
  return w;
}

std::optional<LeaseGrant> Coordinator::lease(const std::string& workerId, double waitSeconds) {
  MutexLock lock(mutex_);
  const auto until =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(waitSeconds));
  for (;;) {
    Worker& worker = findWorker(workerId);
    const auto now = Clock::now();
    worker.lastHeartbeat = now;
    reapExpiredLeases(now);
    if (auto grant = tryLease(worker, now)) return grant;
    worker.currentJobId.clear();
    worker.currentUnit.reset();
    if (now >= until || prefetchFor(worker)) return std::nullopt;  // (then takePrefetch)
    // Wake on new work, and now and then to reap lapsed leases.
    lock.waitUntil(changed_, std::min(until, now + std::chrono::milliseconds(200)));
  }
}

std::vector<uint64_t> Coordinator::heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds) {
  MutexLock lock(mutex_);
  Worker& worker = findWorker(workerId);
  const auto now = Clock::now();
  worker.lastHeartbeat = now;
  std::vector<uint64_t> revoked;
  for (uint64_t id : leaseIds)
    if (!leases_.extend(id, workerId, leaseDeadline(now))) revoked.push_back(id);
  reapExpiredLeases(now);
  return revoked;
}

std::string Coordinator::releaseLeasesOf(Worker& worker, const std::string& verb, const std::string& detail,
                                         Clock::time_point now) {
  std::map<std::string, std::vector<uint64_t>> byJob;
  for (const LeaseTable::Lease& lease : leases_.takeAllOf(worker.id)) {
    Job& job = findJob(lease.jobId);
    const uint64_t unit = lease.unit;
    if (lease.audit) job.audit.audits.release(unit, worker.id);
    // Back in the queue, leased again before any fresh unit; an upload under the old lease is
    // refused from now on, so the unit is still counted once.
    if (!lease.audit && !isTerminal(job.progress.state) && !job.progress.units.isReceived(unit) &&
        !job.progress.units.isRecording(unit) && leases_.unitLeases(job.definition.id, unit).empty())
      job.progress.units.requeue(unit);
    byJob[job.definition.id].push_back(unit);
    ++counters_.unitsExpired;
  }
  std::string requeued;
  for (auto& [jobId, units] : byJob) {
    Job& job = findJob(jobId);
    std::string list;
    for (uint64_t u : units) list += (list.empty() ? "" : ", ") + std::to_string(u);
    const std::string what = (units.size() == 1 ? "unit " : "units ") + list + " of " + jobId + " queued again";
    spdlog::debug("{} {} ({}): {}", logText(worker.label()), verb, logText(detail), what);
    requeued += (requeued.empty() ? "" : "; ") + what;
    if (!isTerminal(job.progress.state)) {
      // The watcher's line (lensfarm watch, status, the dashboard): who went, why, what is redone.
      job.addEvent("worker " + worker.label() + " " + verb + " (" + detail + "): " + what);
    }
    job.failures.lost(worker.info.name.empty() ? worker.id : worker.info.name,
                      JobFailures::Loss{worker.label(), verb, detail, now, std::move(units)},
                      !isTerminal(job.progress.state));
    touch(job);
  }
  worker.currentJobId.clear();
  worker.currentUnit.reset();
  changed_.notify_all();  // idle workers waiting in lease() take the units at once
  return requeued;
}

void Coordinator::revokeLeasesOf(Job& job) {
  leases_.eraseAllOf(job.definition.id);
  job.progress.units.clearPending();
}

}  // namespace lensfarm
