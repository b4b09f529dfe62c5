// Coordinator, scheduling by policy (docs/farm.md "Scheduling"): which jobs may be leased to a
// worker (pause, dependencies, tags, caps, preferred workers), the order among those that may
// (strict priority, then weighted fair share, fair_share.h), and the actions of people on it
// (pause, resume, approve). The unit a lease carries and the lease records are scheduler.cpp's.
//
// Invariants: a job's policy never changes the bits of its image (workers never see it); a
// paused job's leases in flight finish and count, exactly once, as any lease's; a job is
// released (leasable) once all its dependencies held, and stays released.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>

#include "common/util/log_text.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {
namespace {

std::string percentText(double fraction) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g %%", fraction * 100.0);
  return text;
}

}  // namespace

bool Coordinator::policyAllows(const Job& job, const Worker& worker, Clock::time_point now) const {
  const JobPolicy& policy = job.definition.policy;
  if (job.paused || !job.released) return false;
  if (!hasAllTags(worker.info.tags, policy.requireTags)) return false;
  if (policy.maxWorkers) {
    std::set<std::string> rendering;
    for (const LeaseTable::Lease* lease : leases_.ofJob(job.definition.id))
      if (!lease->audit) rendering.insert(lease->workerId);
    if (rendering.size() >= *policy.maxWorkers && !rendering.count(worker.id)) return false;
  }
  if (!policy.preferTags.empty() && !hasAllTags(worker.info.tags, policy.preferTags)) {
    // A worker it prefers that waits for work (connected, holding no lease) takes it instead.
    const std::set<std::string> holders = leases_.holders();
    for (const auto& [id, w] : workers_) {
      if (w.get() == &worker || holders.count(id) || w->gone || w->quarantined) continue;
      double seconds = 0.0;
      if (stateOf(*w, false, now, &seconds) != WorkerState::kIdle) continue;
      if (hasAllTags(w->info.tags, policy.preferTags) && hasAllTags(w->info.tags, policy.requireTags) &&
          job.takes(w->info) && !job.failures.blocks(id))
        return false;
    }
  }
  return true;
}

bool Coordinator::urgent(Job& job, size_t ownersSharing, Clock::time_point now) {
  const RenderSettings& settings = job.definition.settings;
  std::string& outlook = job.progress.deadlineOutlook;
  outlook.clear();
  if (!(settings.targetError > 0.0 && settings.timeLimitSeconds > 0.0)) return false;
  const double nowUnix = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  const double left = job.definition.submittedUnixSeconds + settings.timeLimitSeconds - nowUnix;
  if (!job.progress.estimate.valid || job.progress.pathsCounted == 0 || !(job.progress.renderSeconds > 0.0)) {
    outlook = "measuring: its error and speed are not known yet";
    return false;
  }
  const double error = job.progress.estimate.relativeRmse, target = settings.targetError;
  if (error <= target || left <= 0.0) return false;
  // The error's square falls as 1 / samples (film/convergence.h): the paths to the target, at
  // the job's own measured speed on one worker, spread over the workers that may render it.
  const double pathsLeft = double(job.progress.stats.paths) * ((error / target) * (error / target) - 1.0);
  const double perWorkerSecond = double(job.progress.pathsCounted) / job.progress.renderSeconds;
  const std::set<std::string> holders = leases_.holders();
  size_t workers = 0;
  for (const auto& [id, w] : workers_) {
    double seconds = 0.0;
    const WorkerState state = stateOf(*w, holders.count(id) > 0, now, &seconds);
    workers += (state == WorkerState::kIdle || state == WorkerState::kRendering) && !w->quarantined &&
               job.takes(w->info) && hasAllTags(w->info.tags, job.definition.policy.requireTags) &&
               !job.failures.blocks(id);
  }
  if (job.definition.policy.maxWorkers) workers = std::min<size_t>(workers, *job.definition.policy.maxWorkers);
  if (workers == 0) return false;
  const double needed = pathsLeft / (perWorkerSecond * double(workers));
  const double fair = 1.0 / double(std::max<size_t>(ownersSharing, 1));
  const std::string figures = "about " + secondsText(needed) + " of the farm's " + std::to_string(workers) +
                              " worker(s) to reach " + percentText(target) + " from " + percentText(error) + ", " +
                              secondsText(left) + " left";
  if (needed > left) {
    outlook = "out of reach: " + figures + "; served first, it stops at its deadline with the error it reached";
    if (!job.progress.outOfReachReported) {
      job.progress.outOfReachReported = true;
      job.addEvent("its target error cannot be met by its deadline: " + figures);
    }
  } else if (needed > fair * left) {
    outlook = "at risk: " + figures + ", more than its fair share; served first";
  } else {
    outlook = "on track: " + figures;
  }
  return needed > fair * left;
}

bool Coordinator::leasedBefore(const Job& a, bool urgentA, const Job& b, bool urgentB) const {
  if (a.priority != b.priority) return a.priority > b.priority;
  if (urgentA != urgentB) return urgentA;
  if (urgentA) {  // earliest deadline first (Liu and Layland 1973)
    const double endA = a.definition.submittedUnixSeconds + a.definition.settings.timeLimitSeconds;
    const double endB = b.definition.submittedUnixSeconds + b.definition.settings.timeLimitSeconds;
    if (endA != endB) return endA < endB;
  }
  if (options_.sharing == Options::Sharing::kFairShare) {
    const std::string& ownerA = a.definition.owner;
    const std::string& ownerB = b.definition.owner;
    if (ownerA != ownerB) {
      const double startA = share_.ownerStart(ownerA), startB = share_.ownerStart(ownerB);
      if (startA != startB) return startA < startB;
    } else {
      const double startA = share_.jobStart(ownerA, a.definition.id), startB = share_.jobStart(ownerB, b.definition.id);
      if (startA != startB) return startA < startB;
    }
  }
  return a.definition.sequence < b.definition.sequence;
}

void Coordinator::chargeShare(const Job& job, uint64_t unit) {
  const PixelRegion region = job.definition.layout.regionOf(unit);
  const double cost =
      double(region.width) * double(region.height) * double(job.definition.layout.unit(unit).sampleCount);
  const auto weight = options_.ownerWeights.find(job.definition.owner);
  share_.charge(job.definition.owner, weight == options_.ownerWeights.end() ? 1.0 : weight->second, job.definition.id,
                job.definition.policy.shareWeight, std::max(cost, 1.0));
}

std::vector<std::string> Coordinator::dependencyWaits(const Job& job, std::string* broken) const {
  std::vector<std::string> waits;
  for (const Dependency& d : job.definition.policy.after) {
    const auto it = jobs_.find(d.jobId);
    if (it == jobs_.end()) {
      if (broken && broken->empty()) *broken = d.jobId + ", which it waits for, was deleted";
      continue;
    }
    const Job& other = *it->second;
    const JobState state = other.progress.state;
    const bool ended = isTerminal(state);
    const std::string now = std::string(" (") + jobStateName(state) + ")";
    std::string wait, cannot;
    switch (d.condition) {
      case Dependency::Condition::kDone:
        if (state == JobState::kDone) break;
        if (ended)
          cannot = d.jobId + ", which it waits for to be done, " + jobStateName(state);
        else
          wait = d.jobId + " to be done" + now;
        break;
      case Dependency::Condition::kFailed:
        if (state == JobState::kFailed) break;
        if (ended)
          cannot = d.jobId + ", which it waits for to fail, ended " + jobStateName(state);
        else
          wait = d.jobId + " to fail" + now;
        break;
      case Dependency::Condition::kEnded:
        if (!ended) wait = d.jobId + " to end" + now;
        break;
      case Dependency::Condition::kApproved:
        if (!other.approved) wait = d.jobId + " to be approved (lensfarm approve " + d.jobId + ")";
        break;
      case Dependency::Condition::kErrorAtMost: {
        const bool known = other.progress.estimate.valid;
        const double error = known ? other.progress.estimate.relativeRmse : 0.0;
        if (known && error <= d.maxError) break;
        const std::string at = known ? "now " + percentText(error) : "not estimated yet";
        if (ended)
          cannot = d.jobId + " ended " + jobStateName(state) + " at " + (known ? percentText(error) : "no estimated") +
                   " error, above the " + percentText(d.maxError) + " it waits for";
        else
          wait = d.jobId + " to reach " + percentText(d.maxError) + " error (" + at + ")";
        break;
      }
    }
    if (!cannot.empty() && broken && broken->empty()) *broken = cannot;
    if (!wait.empty()) waits.push_back(wait);
  }
  return waits;
}

void Coordinator::updateDependencies() {
  for (auto& [id, jobPtr] : jobs_) {
    Job& job = *jobPtr;
    if (job.released || isTerminal(job.progress.state)) continue;
    std::string broken;
    const std::vector<std::string> waits = dependencyWaits(job, &broken);
    if (!broken.empty()) {
      if (job.definition.policy.onDependencyFailure == OnDependencyFailure::kFail) {
        job.progress.error = "a dependency can no longer hold: " + broken;
        job.addEvent("failed: " + job.progress.error);
        end(job, JobState::kFailed);
        touch(job);
      } else if (!job.brokenReported) {
        job.brokenReported = true;
        job.addEvent("a dependency can no longer hold (" + broken +
                     "); it waits, as its policy says, until it is cancelled");
        touch(job);
      }
      continue;
    }
    if (!waits.empty()) continue;
    job.released = true;
    std::string held;
    for (const Dependency& d : job.definition.policy.after) held += (held.empty() ? "" : ", ") + dependencyText(d);
    job.addEvent("its dependencies hold (" + held + "): its units are leased from now on");
    persistState(job);
    touch(job);
  }
}

void Coordinator::checkDependenciesExist(const JobPolicy& policy) const {
  for (size_t i = 0; i < policy.after.size(); ++i) {
    const std::string& other = policy.after[i].jobId;
    if (!jobs_.count(other))
      throw FarmError(FarmError::Kind::kNotFound, "after[" + std::to_string(i) + "]: no job " + logText(other) +
                                                      (deletedJobs_.count(other) ? " (it was deleted)" : ""));
  }
}

std::string Coordinator::tagsStall(const Job& job, Clock::time_point now) const {
  const std::vector<std::string>& need = job.definition.policy.requireTags;
  if (need.empty()) return "";
  std::string connected;
  for (const auto& [id, w] : workers_) {
    double seconds = 0.0;
    const WorkerState state = stateOf(*w, false, now, &seconds);
    if (state != WorkerState::kIdle && state != WorkerState::kRendering) continue;
    if (hasAllTags(w->info.tags, need)) return "";
    connected += (connected.empty() ? "" : ", ") + w->label() + " [" + tagsText(w->info.tags) + "]";
  }
  return "no connected worker has the tags it requires (" + tagsText(need) +
         "; connected: " + (connected.empty() ? "none" : connected) + "); start one with --tags " + [&] {
           std::string list;
           for (const std::string& t : need) list += (list.empty() ? "" : ",") + t;
           return list;
         }();
}

JobInfo Coordinator::pauseJob(const std::string& jobId) { return setPaused(jobId, true); }
JobInfo Coordinator::resumeJob(const std::string& jobId) { return setPaused(jobId, false); }

JobInfo Coordinator::setPaused(const std::string& jobId, bool paused) {
  MutexLock lock(mutex_);
  Job& job = findJob(jobId);
  if (isTerminal(job.progress.state))
    throw FarmError(FarmError::Kind::kFailedPrecondition, jobId + " has ended (" + jobStateName(job.progress.state) +
                                                              "): there is nothing to " +
                                                              (paused ? "pause" : "resume"));
  if (job.paused == paused) return infoOf(job);  // changes nothing
  job.paused = paused;
  if (paused) {
    const size_t inFlight = leases_.ofJob(jobId).size();
    job.addEvent("paused: no unit is leased until it is resumed" +
                 (inFlight ? "; " + std::to_string(inFlight) + " lease(s) in flight finish and count" : std::string()));
  } else {
    job.failures.forgetFailures();  // (a job its failure policy paused tries again afresh)
    job.addEvent("resumed");
  }
  notify(job, paused ? farm_event::kJobPaused : farm_event::kJobResumed, paused ? "paused" : "resumed");
  persistState(job);
  touch(job);  // (resumed: wakes the workers waiting for work)
  return infoOf(job);
}

JobInfo Coordinator::approveJob(const std::string& jobId) {
  MutexLock lock(mutex_);
  Job& job = findJob(jobId);
  if (!job.approved) {
    job.approved = true;
    job.addEvent("approved");
    notify(job, farm_event::kJobApproved, "approved");
    persistState(job);
    touch(job);
    updateDependencies();
  }
  return infoOf(job);
}

JobInfo Coordinator::updateJob(const std::string& jobId, const JobUpdate& update) {
  MutexLock lock(mutex_);
  Job& job = findJob(jobId);
  JobPolicy policy = job.definition.policy;
  if (update.maxWorkers) policy.maxWorkers = *update.maxWorkers;
  if (update.shareWeight) policy.shareWeight = *update.shareWeight;
  checkPolicy(policy);  // (a cap of 0, a weight out of range: nothing changes)
  if (update.priority && *update.priority != job.priority) {
    job.priority = *update.priority;
    if (store_) store_->updateJobPriority(job.definition.id, job.priority);
  }
  if (update.maxWorkers || update.shareWeight) {
    job.definition.policy = policy;
    if (store_) store_->updateJobPolicy(job.definition.id, policyToJson(policy));
  }
  spdlog::info("job {}: priority {}, max workers {}, share weight {}", job.definition.id, job.priority,
               policy.maxWorkers ? std::to_string(*policy.maxWorkers) : "any", policy.shareWeight);
  touch(job);  // (a raised cap: wakes the workers waiting for work)
  return infoOf(job);
}

JobInfo Coordinator::prefetchJob(const std::string& jobId) {
  MutexLock lock(mutex_);
  Job& job = findJob(jobId);
  if (isTerminal(job.progress.state))
    throw FarmError(FarmError::Kind::kFailedPrecondition,
                    jobId + " has ended (" + jobStateName(job.progress.state) + "): there is nothing to prefetch");
  if (!job.prefetch) {
    job.prefetch = true;
    job.addEvent("prefetch: the workers that may render it fetch its assets now");
    touch(job);  // (wakes the workers waiting in lease())
  }
  return infoOf(job);
}

const Coordinator::Job* Coordinator::prefetchFor(const Worker& worker) const {
  if (worker.gone || worker.quarantined) return nullptr;
  for (const auto& [id, job] : jobs_)
    if (job->prefetch && !isTerminal(job->progress.state) && !worker.prefetched.count(id) &&
        !job->definition.spec.assets.empty() && hasAllTags(worker.info.tags, job->definition.policy.requireTags))
      return job.get();
  return nullptr;
}

std::string Coordinator::takePrefetch(const std::string& workerId) {
  MutexLock lock(mutex_);
  Worker* worker = liveWorker(workerId);
  const Job* job = worker ? prefetchFor(*worker) : nullptr;
  if (!job) return "";
  worker->prefetched.insert(job->definition.id);
  spdlog::info("{}: fetches the assets of {} ahead", logText(worker->label()), job->definition.id);
  return job->definition.id;
}

std::optional<uint64_t> Coordinator::webhookCursor(const std::string& url) const {
  return store_ ? store_->webhookCursor(url) : std::nullopt;
}

void Coordinator::setWebhookCursor(const std::string& url, uint64_t sequence) {
  if (!store_) return;
  try {
    store_->setWebhookCursor(url, sequence);
  } catch (const std::exception& e) {
    spdlog::warn("webhook {}: progress not kept in the state dir: {}", logText(url), e.what());
  }
}

void Coordinator::notify(const Job& job, const char* type, std::string text) {
  events_.publish(FarmEvent{0, 0.0, type, job.definition.id, "", job.definition.owner, std::move(text)});
}

}  // namespace lensfarm
