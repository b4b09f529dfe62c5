// Coordinator, the workers: registration, the Attach stream's verdicts (attachWorker, workerLost,
// workerLeft), forgetting long-silent workers, each worker's state, and why a job is stalled.
// Leases and heartbeats are in scheduler.cpp; the records the files share are in
// coordinator_records.h.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "common/farm/memory_estimate.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"

namespace lensfarm {

const char* workerStateName(WorkerState s) {
  switch (s) {
    case WorkerState::kRendering: return "rendering";
    case WorkerState::kIdle: return "idle";
    case WorkerState::kStale: return "stale";
    case WorkerState::kLost: return "lost";
    case WorkerState::kLeft: return "left";
  }
  return "?";
}

std::string Coordinator::registerWorker(const WorkerInfo& info, std::string* session) {
  if (info.protocolVersion != kProtocolVersion || info.rendererVersion != kRendererVersion)
    throw FarmError(FarmError::Kind::kFailedPrecondition, "version mismatch: worker speaks " + info.protocolVersion +
                                                              " with renderer " + info.rendererVersion +
                                                              ", coordinator speaks " + kProtocolVersion +
                                                              " with renderer " + kRendererVersion);
  MutexLock lock(mutex_);
  const auto now = Clock::now();
  // One machine, one registration: the credential's live worker gives its leases back first.
  if (Worker* earlier = workers_.liveByCredential(info.credential)) {
    const std::string requeued =
        releaseLeasesOf(*earlier, "superseded", "another worker registered with credential " + info.credential, now);
    spdlog::warn("{}: superseded by a new registration of credential {}{}", logText(earlier->label()), info.credential,
                 requeued.empty() ? "" : "; " + requeued);
  }
  bool back = false;
  WorkerRecord& worker = workers_.add(info, now, &back);
  if (session) *session = worker.session;
  const std::string id = worker.id;
  spdlog::info("{} registered: {} with {} threads{}", id, logText(info.name), info.threads,
               info.credential.empty() ? "" : " (credential " + info.credential + ")");
  events_.publish(
      FarmEvent{0, 0.0, farm_event::kWorkerJoined, "", id, "",
                info.name + " with " + std::to_string(info.threads) + " threads" + (back ? " (again)" : "")});
  if (back)
    for (auto& [jobId, job] : jobs_)
      if (!isTerminal(job->progress.state) && job->failures.rejoined(info.name)) {
        job->addEvent("worker " + info.name + " (" + id + ") rejoined");
        touch(*job);
      }
  return id;
}

void Coordinator::authenticateWorker(const std::string& workerId, const std::string& session) {
  MutexLock lock(mutex_);
  workers_.authenticate(workerId, session);
}

void Coordinator::setWorkerEpoch() {
  MutexLock lock(mutex_);
  workers_.setEpoch(epoch_);
}

Coordinator::Worker& Coordinator::findWorker(const std::string& workerId) { return workers_.find(workerId); }

Coordinator::Worker* Coordinator::liveWorker(const std::string& workerId) { return workers_.live(workerId); }

double Coordinator::staleAfterSeconds() const { return std::max(3.0, 5.0 * options_.heartbeatIntervalSeconds); }

void Coordinator::forgetSilentWorkers(Clock::time_point now) {
  // Forget workers silent for much longer than a lease: they hold nothing any more.
  const auto forgetAfter = std::chrono::duration<double>(std::max(60.0, 10.0 * options_.leaseTimeoutSeconds));
  workers_.forgetSilent(now, std::chrono::duration_cast<Clock::duration>(forgetAfter));
}

uint64_t Coordinator::attachWorker(const std::string& workerId) {
  MutexLock lock(mutex_);
  Worker& worker = findWorker(workerId);
  worker.attachment = nextAttachment_++;
  worker.lastHeartbeat = Clock::now();
  spdlog::debug("{} attached (stream {})", logText(worker.label()), worker.attachment);
  return worker.attachment;
}

bool Coordinator::workerLost(const std::string& workerId, const std::string& reason, uint64_t attachment) {
  MutexLock lock(mutex_);
  Worker* worker = liveWorker(workerId);
  if (!worker || (attachment != 0 && worker->attachment != attachment)) return false;  // gone, or a superseded stream
  const auto now = Clock::now();
  worker->gone = WorkerState::kLost;
  worker->goneAt = now;
  worker->attachment = 0;
  ++counters_.workersLost;
  const std::string requeued = releaseLeasesOf(*worker, "lost", reason, now);
  worker->goneReason = reason + (requeued.empty() ? "" : "; " + requeued);
  spdlog::warn("{} lost: {}", logText(worker->label()), logText(worker->goneReason));
  events_.publish(
      FarmEvent{0, 0.0, farm_event::kWorkerLost, "", worker->id, "", worker->label() + ": " + worker->goneReason});
  return true;
}

void Coordinator::workerLeft(const std::string& workerId, uint64_t attachment) {
  MutexLock lock(mutex_);
  Worker* worker = liveWorker(workerId);
  if (!worker || (attachment != 0 && worker->attachment != attachment)) return;
  const auto now = Clock::now();
  worker->gone = WorkerState::kLeft;
  worker->goneAt = now;
  worker->attachment = 0;
  const std::string requeued = releaseLeasesOf(*worker, "left", "stopped", now);
  worker->goneReason = "stopped" + (requeued.empty() ? std::string() : "; " + requeued);
  spdlog::info("{} left: {}", logText(worker->label()), logText(worker->goneReason));
}

WorkerState Coordinator::stateOf(const Worker& worker, bool holdsLease, Clock::time_point now,
                                 double* secondsInState) const {
  const double silent = std::chrono::duration<double>(now - worker.lastHeartbeat).count();
  *secondsInState = 0.0;
  if (worker.gone) {
    *secondsInState = std::chrono::duration<double>(now - worker.goneAt).count();
    return *worker.gone;
  }
  // A worker without an Attach stream is judged by its heartbeats alone, as before.
  if (worker.attachment == 0 && silent > options_.leaseTimeoutSeconds) {
    *secondsInState = silent - options_.leaseTimeoutSeconds;
    return WorkerState::kLost;
  }
  if (silent > staleAfterSeconds()) {
    *secondsInState = silent;
    return WorkerState::kStale;
  }
  return holdsLease ? WorkerState::kRendering : WorkerState::kIdle;
}

std::string Coordinator::stalledReason(const Job& job, Clock::time_point now) const {
  if (isTerminal(job.progress.state)) return "";
  if (storageStall_)
    return "the coordinator cannot write its state dir (" + storageStall_->reason + ") for " +
           secondsText(std::chrono::duration<double>(now - storageStall_->since).count()) +
           ": no unit is leased until it can; rendering resumes by itself";
  if (job.paused) {
    const size_t inFlight = leases_.ofJob(job.definition.id).size();
    return "paused: no unit is leased until it is resumed (lensfarm resume " + job.definition.id + ")" +
           (inFlight ? "; " + std::to_string(inFlight) + " lease(s) in flight finish and count" : std::string());
  }
  if (!job.released) {
    std::string broken;
    const std::vector<std::string> waits = dependencyWaits(job, &broken);
    std::string text;
    for (const std::string& w : waits) text += (text.empty() ? "" : "; ") + w;
    if (!broken.empty()) return "a dependency can no longer hold (" + broken + "); it waits until it is cancelled";
    return "waiting for " + text;
  }
  if (job.audit.stopAwaitingAudits && !job.audit.audits.empty()) {
    // Every unit is in: what is left is rendering some again, by other workers, to check them.
    const double waited = std::chrono::duration<double>(now - job.audit.awaitingSince).count();
    size_t leased = 0;
    for (const auto& [unit, audit] : job.audit.audits.audits()) leased += audit.leasedTo.has_value();
    return "every unit is in; waiting for " + std::to_string(job.audit.audits.size()) +
           " audit(s) by workers that did not render those units (" + std::to_string(leased) +
           " being rendered); one not taken is waived in " +
           secondsText(std::max(0.0, options_.auditWaitSeconds - waited));
  }
  const std::set<std::string> holders = leases_.holders();  // workers holding a lease of any job
  // Held by a worker that is heard from: it is being rendered.
  std::string silent;
  for (const LeaseTable::Lease* lease : leases_.ofJob(job.definition.id)) {
    const Worker* holder = workers_.known(lease->workerId);
    if (!holder) continue;
    double s = 0.0;
    const WorkerState state = stateOf(*holder, true, now, &s);
    if (state == WorkerState::kRendering) return "";
    if (silent.empty())
      silent = "worker " + holder->label() + " silent for " + secondsText(s) + "; unit " + std::to_string(lease->unit) +
               " is queued again when its lease lapses in " +
               secondsText(std::chrono::duration<double>(lease->deadline - now).count());
  }
  if (!silent.empty()) return silent;
  if (!job.progress.units.hasPending()) return "";  // every unit is in or being recorded
  if (std::string tags = tagsStall(job, now); !tags.empty()) return tags;
  uint64_t busyElsewhere = 0, tooSmall = 0, largest = 0, otherKernel = 0;
  std::set<std::string> kernelsRun;  // by the connected workers without the job's kernel
  const Worker* recentlyGone = nullptr;
  for (const auto& [id, w] : workers_) {
    double s = 0.0;
    const WorkerState state = stateOf(*w, holders.count(id) > 0, now, &s);
    if ((state == WorkerState::kIdle || state == WorkerState::kRendering) && !job.definition.fitsOn(w->info)) {
      ++tooSmall;  // connected, but never leased a unit of this job
      largest = std::max(largest, w->info.maxUnitMemoryBytes);
      continue;
    }
    if ((state == WorkerState::kIdle || state == WorkerState::kRendering) && !job.takes(w->info)) {
      ++otherKernel;  // connected, but it cannot run the kernel the job's units are traced with
      kernelsRun.insert(w->info.kernels.back());
      continue;
    }
    switch (state) {
      case WorkerState::kIdle: return "";  // it is about to lease a unit
      case WorkerState::kRendering: ++busyElsewhere; break;
      case WorkerState::kLost:
      case WorkerState::kLeft:
        if (w->gone && (!recentlyGone || w->goneAt > recentlyGone->goneAt)) recentlyGone = w.get();
        break;
      case WorkerState::kStale: break;
    }
  }
  // Just submitted: give the workers (or `lensfarm render`'s own) a moment to call in.
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const std::optional<JobFailures::Loss>& lastLoss = job.failures.lastLoss();
  const bool recentLoss = lastLoss && now - lastLoss->when < std::chrono::seconds(120);
  if (!recentLoss && nowUnix - job.definition.submittedUnixSeconds < 2.0) return "";
  std::string why;
  if (recentLoss) {
    const JobFailures::Loss& loss = *lastLoss;
    std::string units;
    for (uint64_t u : loss.units) units += (units.empty() ? "" : ", ") + std::to_string(u);
    why = "worker " + loss.worker + " " + loss.verb + " " +
          secondsText(std::chrono::duration<double>(now - loss.when).count()) + " ago (" + loss.detail + "); " +
          (loss.units.size() == 1 ? "unit " : "units ") + units + " queued again; ";
  }
  if (tooSmall && !busyElsewhere)
    why += "no connected worker can hold a unit of this job: it needs " + formatBytes(job.definition.unitMemoryBytes) +
           " of worker memory, the largest of the " + std::to_string(tooSmall) + " connected allows " +
           formatBytes(largest) + " (LENSFARM_MAX_JOB_MEMORY on a worker); lower the resolution or add a bigger worker";
  else if (otherKernel && !busyElsewhere) {
    std::string run;
    for (const std::string& k : kernelsRun) run += (run.empty() ? "" : " or ") + k;
    why += "no connected worker runs this job's traversal kernel " + job.kernel + " (pinned when its first unit " +
           "was leased, docs/farm.md \"Mixed machines\"); the " + std::to_string(otherKernel) +
           " connected run at most " + run + ": start a worker that runs " + job.kernel +
           ", or submit the job again with --kernel " + *kernelsRun.begin();
  } else if (busyElsewhere)
    why += "waiting for a worker: " +
           (busyElsewhere == 1 ? std::string("the only one is") : "all " + std::to_string(busyElsewhere) + " are") +
           " rendering other jobs";
  else
    why += "no workers connected";
  if (!recentLoss && !busyElsewhere && recentlyGone && now - recentlyGone->goneAt < std::chrono::seconds(120))
    why += " (" + recentlyGone->label() + " " + workerStateName(*recentlyGone->gone) + " " +
           secondsText(std::chrono::duration<double>(now - recentlyGone->goneAt).count()) +
           " ago: " + recentlyGone->goneReason + ")";
  return why;
}

std::vector<WorkerView> Coordinator::workers() const {
  MutexLock lock(mutex_);
  std::vector<WorkerView> out;
  const auto now = Clock::now();
  const std::set<std::string> holders = leases_.holders();
  for (const auto& [id, w] : workers_) {
    WorkerView v;
    v.id = w->id;
    v.info = w->info;
    v.currentJobId = w->currentJobId;
    v.unitsDone = w->unitsDone;
    v.secondsSinceHeartbeat = std::chrono::duration<double>(now - w->lastHeartbeat).count();
    v.currentUnit = w->currentUnit;
    v.samplesPerSecond = w->samplesPerSecond;
    v.state = stateOf(*w, holders.count(id) > 0, now, &v.secondsInState);
    v.attached = w->attachment != 0;
    v.failures = w->failures;
    v.auditsPassed = w->auditsPassed;
    v.auditsRendered = w->auditsRendered;
    v.registrations = w->registrations;
    v.quarantined = w->quarantined;
    v.quarantineReason = w->quarantineReason;
    for (const auto& [jobId, job] : jobs_)
      if (job->failures.blocks(id)) v.blocklistedJobs.push_back(jobId);
    if (w->gone)
      v.stateReason = w->goneReason;
    else if (v.state == WorkerState::kLost)
      v.stateReason = "no heartbeat for " + secondsText(v.secondsSinceHeartbeat) + " (not attached)";
    else if (v.state == WorkerState::kIdle)
      for (const auto& [jobId, job] : jobs_)  // idle beside work it cannot take: say why
        if (!isTerminal(job->progress.state) && job->progress.units.hasPending() &&
            !runsKernel(w->info.kernels, job->kernel)) {
          std::string runs;
          for (const std::string& k : w->info.kernels) runs += (runs.empty() ? "" : ", ") + k;
          v.stateReason = "not leased " + jobId + ": its units are traced with kernel " + job->kernel +
                          ", this worker runs " + runs;
          break;
        }
    if (!holders.count(id)) {  // it holds nothing now
      v.currentJobId.clear();
      v.currentUnit.reset();
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace lensfarm
