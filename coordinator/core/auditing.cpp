// Coordinator, the cross-worker audit (docs/farm.md "Audit"; one job's units under audit are its
// AuditBook, audit.h): which counted units are rendered again and by whom, what a verdict does,
// and when a job whose film reached its stop may end.
//
// A unit's counted result is summed into the film at once (the audit costs no latency); a
// verdict that finds its worker wrong quarantines it and rewinds the film to a point before the
// worker's first unit since its last agreeing audit (Accumulator::rewind: a bitwise copy of the
// film), so every unit from there on is rendered again by the others and summed in the same
// order: the image is bit for bit the one a farm without the wrong worker makes.
#include <spdlog/spdlog.h>

#include <algorithm>

#include "common/film/work_unit.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/core/result_checks.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

void Coordinator::Job::addEvent(std::string text) {
  spdlog::info("job {}: {}", definition.id, logText(text));
  if (events.size() >= kMaxJobEvents) events.erase(events.begin());
  const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  events.push_back(JobInfo::Event{now, std::move(text)});
}

bool Coordinator::mayAudit(const Job& job, const Worker& worker, const std::string& exceptWorker) const {
  // Only a worker heard from lately: a silent one would hold the job's end back.
  const bool heard = Clock::now() - worker.lastHeartbeat < std::chrono::duration<double>(staleAfterSeconds());
  // Its tags: those the job requires of every worker, and those it requires of its auditors (a
  // job may ask for its audits on another class of machine, docs/farm.md "Scheduling").
  const JobPolicy& policy = job.definition.policy;
  return heard && !worker.gone && !worker.quarantined && worker.id != exceptWorker && job.takes(worker.info) &&
         !job.failures.blocks(worker.id) && hasAllTags(worker.info.tags, policy.requireTags) &&
         hasAllTags(worker.info.tags, policy.auditRequireTags);
}

bool Coordinator::chooseForAudit(const Job& job, Worker& worker) {
  if (!(options_.auditFraction > 0.0)) return false;
  bool another = false;
  for (const auto& [id, w] : workers_) another = another || mayAudit(job, *w, worker.id);
  if (!another) return false;  // a farm of one: nobody to compare with
  if (!worker.firstUnitAudited) {
    worker.firstUnitAudited = true;
    return true;
  }
  return std::uniform_real_distribution<double>(0.0, 1.0)(auditRandom_) < options_.auditFraction;
}

std::optional<LeaseGrant> Coordinator::tryAuditLease(Worker& worker, Clock::time_point now) {
  Job* best = nullptr;
  for (auto& [id, job] : jobs_) {
    if (isTerminal(job->progress.state) || job->paused || job->audit.audits.empty() || !mayAudit(*job, worker) ||
        !job->audit.audits.offers(worker.id))
      continue;
    if (!best || job->servedBefore(*best)) best = job.get();
  }
  if (!best) return std::nullopt;
  Job& job = *best;
  const uint64_t unit = *job.audit.audits.lease(worker.id);
  bool ready = true;
  WorkUnit leased = unitToLease(job, unit, &ready);
  if (!ready) {  // a unit of a round a rewind undid: its allocation is made again first
    job.audit.audits.release(unit, worker.id);
    return std::nullopt;
  }
  const auto longest = longestLeaseEnd(job, now);
  // The grant looks like any other: a worker cannot tell an audit from a unit queued again.
  const uint64_t leaseId =
      leases_.grant(worker.id, job.definition.id, unit, leaseDeadline(now), longest, /*audit=*/true);
  ++counters_.unitsLeased;
  worker.currentJobId = job.definition.id;
  worker.currentUnit = unit;
  touch(job);
  return grantOf(job, leaseId, std::move(leased));
}

bool Coordinator::acceptAudit(const UnitResult& result) {
  const uint64_t unit = result.unitIndex;
  AuditBook::Sums counted, dissent;
  {
    MutexLock lock(mutex_);
    Job& job = findJob(result.jobId);
    checkLeaseHeld(leases_, result.leaseId, result.workerId, result.jobId, unit);
    checkRegion(job, unit, result.buffer.width, result.buffer.height);  // the whole frame, or the unit's tile
    checkSumCount(job, unit, result.buffer.sums.size());
    leases_.erase(result.leaseId);
    Worker& worker = findWorker(result.workerId);
    if (worker.currentUnit == unit) worker.currentUnit.reset();
    const AuditBook::Audit* audit = job.audit.audits.find(unit);
    if (!audit || isTerminal(job.progress.state)) return true;  // closed meanwhile: nothing left to settle
    counted = audit->counted.sums;
    if (audit->dissent) dissent = audit->dissent->sums;
  }
  // Each comparison reads a whole frame: outside the lock. A dissent withdrawn meanwhile (its
  // worker quarantined) is compared again with what the audit holds now.
  for (;;) {
    const std::optional<std::string> fromCounted =
        sumsDiffer(*counted, result.buffer.sums, options_.auditTolerance, result.buffer.channels);
    const std::optional<std::string> fromDissent =
        dissent ? sumsDiffer(*dissent, result.buffer.sums, options_.auditTolerance, result.buffer.channels)
                : std::nullopt;
    AuditBook::Sums mine;  // kept only if it disputes the counted result
    if (fromCounted && !dissent) mine = std::make_shared<const std::vector<double>>(result.buffer.sums);
    // Whether the differences this result makes look like two machines' rounding (read only when
    // a verdict names a wrong worker of another build).
    const int channels = result.buffer.channels;
    const bool rounding =
        (!fromCounted ||
         differenceLooksLikeRounding(*counted, result.buffer.sums, options_.auditTolerance, channels)) &&
        (!fromDissent || differenceLooksLikeRounding(*dissent, result.buffer.sums, options_.auditTolerance, channels));

    MutexLock lock(mutex_);
    Job& job = findJob(result.jobId);
    const AuditBook::Audit* audit = job.audit.audits.find(unit);
    // Closed meanwhile, or its unit counted again and audited anew (not under this lease).
    if (!audit || isTerminal(job.progress.state) || audit->counted.sums != counted ||
        audit->leasedTo != result.workerId)
      return true;
    const AuditBook::Sums now = audit->dissent ? audit->dissent->sums : nullptr;
    if (now != dissent) {
      dissent = now;
      continue;
    }
    if (const auto verdict =
            job.audit.audits.settle(unit, {result.workerId, std::move(mine)}, fromCounted, fromDissent))
      applyVerdict(job, *verdict, rounding);
    touch(job);
    return true;
  }
}

std::string Coordinator::buildOf(const std::string& workerId) const {
  const Worker* w = workers_.known(workerId);
  if (!w) return "unknown";
  return (w->info.build.empty() ? std::string("build not said") : w->info.build) +
         (w->info.kernels.empty() ? ", kernel not said" : "");
}

void Coordinator::applyVerdict(Job& job, const AuditBook::Verdict& v, bool rounding) {
  const auto labelOf = [&](const std::string& id) {
    mutex_.assertHeld();  // the lambdas run here, under the caller's lock
    return workers_.labelOf(id);
  };
  // A worker whose result agreed was right then, so are the units it delivered before. Each
  // audit is counted once per worker, by role: its own unit confirmed, or another's checked.
  const auto vouchFor = [&](const std::string& id, uint64_t seq, bool ownUnit) {
    mutex_.assertHeld();
    if (Worker* w = workers_.known(id)) {
      w->clearedSeq = std::max(w->clearedSeq, seq);
      ++(ownUnit ? w->auditsPassed : w->auditsRendered);
    }
  };
  const std::string unit = "unit " + std::to_string(v.unit);
  switch (v.kind) {
    case AuditBook::Verdict::Kind::kAgreed:
      vouchFor(v.right[0], v.acceptedSeq, true);         // the counted result's worker, up to that result
      vouchFor(v.right[1], nextAcceptance_ - 1, false);  // the auditor, up to now
      ++job.audit.auditsPassed;
      ++counters_.auditsPassed;
      updateTrust(job);
      break;
    case AuditBook::Verdict::Kind::kDisputed:
      job.addEvent("audit of " + unit + ": the results of " + labelOf(job.audit.audits.find(v.unit)->counted.worker) +
                   " and " + labelOf(job.audit.audits.find(v.unit)->dissent->worker) + " " + v.detail +
                   "; a third worker decides");
      break;
    case AuditBook::Verdict::Kind::kSettled: {
      {
        // The counted worker is right[0] when it was right; otherwise both rendered it again.
        const AuditBook::Audit* audit = job.audit.audits.find(v.unit);
        const bool countedRight = audit && audit->counted.worker == v.right[0];
        vouchFor(v.right[0], v.acceptedSeq, countedRight);
        vouchFor(v.right[1], nextAcceptance_ - 1, false);
      }
      // An honest difference of machines (docs/farm.md "Mixed machines"): another build, or a
      // kernel not said, whose result differs as rounding does. Explained, never punished.
      const std::string wrongBuild = buildOf(v.wrong), rightBuild = buildOf(v.right[0]);
      if (rounding && wrongBuild != rightBuild && rightBuild == buildOf(v.right[1])) {
        ++job.audit.auditsExplained;
        ++counters_.auditsExplained;
        job.addEvent("audit of " + unit + ": " + labelOf(v.wrong) + "'s result " + v.detail + " from " +
                     labelOf(v.right[0]) + "'s and " + labelOf(v.right[1]) + "'s, as two builds' rounding does (" +
                     labelOf(v.wrong) + ": " + wrongBuild + "; the others: " + rightBuild +
                     "): a difference of machines, not a wrong result; nobody is quarantined and the counted "
                     "result stands");
        updateTrust(job);
        break;
      }
      const std::string reason = unit + " of " + job.definition.id + ": its sums " + v.detail + " from those of " +
                                 labelOf(v.right[0]) + " and " + labelOf(v.right[1]) + ", which agree" +
                                 (wrongBuild != rightBuild ? " (by more than two builds' rounding)" : "");
      ++job.audit.auditsFailed;
      ++counters_.auditsFailed;
      job.addEvent("audit of " + unit + ": " + labelOf(v.wrong) + " is wrong (" + v.detail + " from " +
                   labelOf(v.right[0]) + " and " + labelOf(v.right[1]) + ", which agree)");
      events_.publish(
          FarmEvent{0, 0.0, farm_event::kAuditFailed, job.definition.id, v.wrong, job.definition.owner, reason});
      if (Worker* w = workers_.known(v.wrong)) quarantine(*w, reason);
      updateTrust(job);
      break;
    }
    case AuditBook::Verdict::Kind::kInconclusive:
      job.addEvent("audit of " + unit + " inconclusive: three workers' results disagree (" + v.detail +
                   "); nobody is quarantined and the counted result stands. Is the scene rendered "
                   "deterministically on every worker?");
      break;
  }
  settleWaitingJobs();
}

void Coordinator::quarantine(Worker& worker, const std::string& reason) {
  // Found wrong again (a unit counted before its quarantine, audited after): its units are
  // undone all the same.
  const bool first = !worker.quarantined;
  if (first) {
    worker.quarantined = true;
    worker.quarantineReason = reason;
    spdlog::warn("worker {} quarantined: {}", logText(worker.label()), logText(reason));
    events_.publish(FarmEvent{0, 0.0, farm_event::kWorkerQuarantined, "", worker.id, "", reason});
    releaseLeasesOf(worker, "quarantined", reason, Clock::now());
  }
  for (auto& [id, job] : jobs_) {
    job->audit.audits.forgetWorker(worker.id);
    if (!isTerminal(job->progress.state)) {
      rewindFor(*job, worker.id);
      continue;
    }
    // A job that ended before: its image may hold the worker's wrong units. Say so.
    uint64_t suspect = 0;
    for (const auto& [unit, p] : job->audit.provenance) suspect += p.uncleared(worker.id, worker.clearedSeq);
    if (first && suspect > 0)
      job->addEvent("worker " + worker.label() + " was quarantined after this job ended; " + std::to_string(suspect) +
                    " of its units since its last agreeing audit are in this image (render the job again)");
  }
  changed_.notify_all();
}

void Coordinator::rewindFor(Job& job, const std::string& workerId) {
  const Worker* w = workers_.known(workerId);
  const uint64_t cleared = w ? w->clearedSeq : 0;
  std::optional<uint64_t> first;  // its first unit since its last agreeing audit
  for (const auto& [unit, p] : job.audit.provenance)
    if (p.uncleared(workerId, cleared)) {
      first = unit;
      break;
    }
  if (!first) return;
  std::lock_guard checkpointLock(checkpointMutex_);  // no checkpoint of the film as it is now
  const Accumulator::Rewound r = job.film->rewind(
      *first, [&](const UnitResult& result) { return result.workerId == workerId; }, workerId);
  job.audit.generation = job.film->generation();
  // An adaptive job's rounds after the film's new end are allocated again: a unit leased under
  // the old allocation traces other samples, so its lease ends here (its unit is leased again).
  if (job.definition.layout.adaptive()) leases_.eraseUnitsOf(job.definition.id);
  const uint64_t uncounted = job.progress.units.rewindTo(r.units, r.kept);
  job.progress.publish(r.progress);
  if (r.progress.stopReason.empty()) {  // the stop was reached with units now undone
    job.audit.stopAwaitingAudits.reset();
    job.progress.stopUnits.reset();
  } else {
    job.progress.units.clearPending();
  }
  for (auto it = job.audit.provenance.lower_bound(r.units); it != job.audit.provenance.end();)
    it = r.kept.count(it->first) ? std::next(it) : job.audit.provenance.erase(it);
  job.audit.trustedUnits = std::min(job.audit.trustedUnits, r.units);
  job.audit.unitsRerendered += uncounted;
  counters_.unitsRerendered += uncounted;
  if (store_) {
    store_->forgetUnits(job.definition.id, r.units, r.kept);
    if (r.checkpoint) {
      store_->writeCheckpoint(job.definition.id, r.checkpoint->sensor, r.checkpoint->tracker, r.checkpoint->folded);
      job.film->checkpointed(r.checkpoint->folded);
    }
  }
  const std::string label = workers_.labelOf(workerId);
  job.addEvent("worker " + label + " quarantined; its units from unit " + std::to_string(*first) +
               " on are rendered again: the film is back at unit " + std::to_string(r.units) + ", " +
               std::to_string(uncounted) + " counted unit(s) undone");
  touch(job);
}

void Coordinator::updateTrust(Job& job) {
  // The first counted unit not vouched for by a later agreeing audit of its worker, or the first
  // unit not counted yet: every unit below it is never undone.
  uint64_t trusted = job.progress.units.countedPrefix();
  for (const auto& [unit, p] : job.audit.provenance) {
    if (unit >= trusted) break;
    const Worker* w = workers_.known(p.worker);
    if (!w || p.seq > w->clearedSeq) {
      trusted = unit;
      break;
    }
  }
  if (trusted <= job.audit.trustedUnits) return;
  job.audit.trustedUnits = trusted;
  job.audit.provenance.erase(job.audit.provenance.begin(), job.audit.provenance.lower_bound(trusted));
  job.film->trustBelow(trusted);
}

void Coordinator::settleWaitingJobs() {
  for (auto& [id, jobPtr] : jobs_) {
    Job& job = *jobPtr;
    if (isTerminal(job.progress.state) || !job.audit.stopAwaitingAudits) continue;
    const double waited = std::chrono::duration<double>(Clock::now() - job.audit.awaitingSince).count();
    std::vector<std::pair<uint64_t, std::string>> orphans;
    for (const auto& [unit, audit] : job.audit.audits.audits()) {
      if (audit.leasedTo) continue;
      std::string able;
      for (const auto& [wid, w] : workers_)
        if (mayAudit(job, *w) && !audit.renderedBy.count(wid)) able += (able.empty() ? "" : ", ") + w->label();
      if (able.empty())
        orphans.emplace_back(unit, "no other worker is left to render it");
      else if (waited >= options_.auditWaitSeconds)
        orphans.emplace_back(unit, "waived after " + secondsText(waited) + ": the workers that could render it (" +
                                       able + ") did not take it");
    }
    for (const auto& [unit, why] : orphans) {
      job.addEvent("audit of unit " + std::to_string(unit) + " not settled: " + why + "; the counted result stands");
      job.audit.audits.close(unit);
    }
    if (!job.audit.audits.empty()) continue;
    const std::string reason = *job.audit.stopAwaitingAudits;
    job.audit.stopAwaitingAudits.reset();
    finish(job, reason);
    touch(job);
  }
}

}  // namespace lensfarm
