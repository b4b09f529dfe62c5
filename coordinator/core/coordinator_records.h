#pragma once
// The coordinator's private records, shared by the files that implement Coordinator
// (coordinator.h lists them). Nothing outside coordinator/core/ includes this header; every field is
// guarded by Coordinator::mutex_ unless its comment says otherwise.
//
// A Job's state is grouped by concern: what it is (JobDefinition), how far it has come
// (JobProgress), what went wrong on its workers (JobFailures, job_failures.h), its cross-worker
// audit (JobAudit) and its life cycle (JobRetention). The groups are plain records of the Job
// that holds them, guarded by Coordinator::mutex_ as every field of Job (Clang's analysis cannot
// name a lock of Coordinator from them, so the rule is written here, on each).
#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/farm/job_layout.h"
#include "common/film/diffraction_psf.h"
#include "common/scene/scene.h"
#include "common/util/trace_kernel.h"
#include "coordinator/core/accumulator.h"
#include "coordinator/core/audit.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/job_failures.h"
#include "coordinator/core/job_units.h"

namespace lensfarm {

// "12 s": a span for people, in whole seconds (stalled reasons, events).
inline std::string secondsText(double seconds) { return std::to_string(long(std::max(0.0, seconds) + 0.5)) + " s"; }

// What a job is, fixed at submission (Coordinator::submit, or jobFromRow at a restart) before the
// job is listed, and never changed after. Guarded by Coordinator::mutex_ (Coordinator::Job::definition).
struct JobDefinition {
  std::string id;
  JobSpec spec;
  uint64_t sequence = 0;
  double submittedUnixSeconds = 0.0;
  RenderSettings settings;
  std::string sceneHash;
  uint32_t unitSize = 1;
  JobLayout layout;              // how the job is cut into units (farm/job_layout.h), fixed at submission
  uint64_t unitMemoryBytes = 0;  // what one unit takes on a worker (workerJobMemory); leases skip smaller workers
  // Whether `worker` can hold one unit (WorkerInfo::maxUnitMemoryBytes; 0: it did not say).
  bool fitsOn(const WorkerInfo& worker) const {
    return worker.maxUnitMemoryBytes == 0 || unitMemoryBytes <= worker.maxUnitMemoryBytes;
  }
  std::vector<std::string> effects;  // what the renderer simulates for this job, and why
  // The point-spread function of the aperture applied to every developed image (film/diffraction_psf.h);
  // null when the scene asks for none. Set by setScene, before the job is published; never changed.
  std::shared_ptr<const DiffractionKernel> diffraction;
  // Fixes the above from the job's scene, loaded with its overrides (Coordinator::Job::setScene
  // also sizes the job's `units` from its layout).
  void setScene(const Scene& scene);
  std::string owner;  // who submitted it (JobInfo::owner; the job life cycle, lifecycle.cpp)
  JobPolicy policy;   // how it is scheduled (farm/job_policy.h, scheduling.cpp)
};

// How far a job has come: its state, its units and the accumulation's published progress.
// Guarded by Coordinator::mutex_ (Coordinator::Job::progress).
struct JobProgress {
  using Clock = std::chrono::steady_clock;  // Coordinator's

  // Scheduling, guarded by Coordinator::mutex_.
  JobState state = JobState::kQueued;
  std::string error;
  JobUnits units;  // to lease, being recorded, counted
  std::optional<Clock::time_point> started;
  std::optional<Clock::time_point> finished;
  std::map<std::string, uint64_t> unitsByWorker;  // provenance
  std::map<std::string, uint64_t> unitsByBuild;   // the same by build and kernel (LedgerEntry::build)
  // The job's speed on one worker (the deadline-aware share, scheduling.cpp): camera paths of the
  // units counted this run, and the seconds the workers said they took to render them.
  uint64_t pathsCounted = 0;
  double renderSeconds = 0.0;
  // The outlook of a job with a target error and a deadline (JobInfo::deadlineOutlook), and
  // whether its target was said to be out of reach in an event (once).
  std::string deadlineOutlook;
  bool outOfReachReported = false;
  uint64_t version = 1;
  // Published accumulation progress (copied from the accumulator under mutex_).
  uint64_t unitsAdded = 0;
  uint64_t samplesPerPixelDone = 0;
  PathStats stats;
  ErrorEstimate estimate;
  void publish(const Accumulator::Progress& progress) {
    unitsAdded = progress.units;
    samplesPerPixelDone = progress.samplesPerPixel;
    stats = progress.stats;
    estimate = progress.estimate;
  }
  std::string stopReason;             // why a finished job stopped
  std::optional<uint64_t> stopUnits;  // a job stopped early keeps units [0, stopUnits)
  bool deadlinePassed = false;
  std::vector<ErrorPoint> history;  // guarded by Coordinator::mutex_; see recordEstimate()
};

// The cross-worker audit (audit.h, auditing.cpp), guarded by Coordinator::mutex_
// (Coordinator::Job::audit): the units under audit; who each counted unit from `trustedUnits` on
// came from and when it was accepted (Coordinator's acceptance sequence), for a rewind; units
// [0, trustedUnits) were delivered by workers that a later audit found right, and are never undone.
struct JobAudit {
  AuditBook audits;
  struct Provenance {
    std::string worker;
    uint64_t seq = 0;
    // Delivered by `workerId` after its last agreeing audit (`clearedSeq`, WorkerRecord::clearedSeq):
    // undone when that worker is found wrong.
    bool uncleared(const std::string& workerId, uint64_t clearedSeq) const {
      return worker == workerId && seq > clearedSeq;
    }
  };
  std::map<uint64_t, Provenance> provenance;
  uint64_t trustedUnits = 0;
  uint64_t generation = 0;  // the film's (Accumulator::generation): grows with every rewind
  // The stop the film reached while audits were pending: the job ends with it once they settle.
  std::optional<std::string> stopAwaitingAudits;
  std::chrono::steady_clock::time_point awaitingSince;  // when stopAwaitingAudits was set
  uint64_t auditsPassed = 0, auditsFailed = 0, unitsRerendered = 0;
  uint64_t auditsExplained = 0;  // disagreements explained by the workers' builds (auditing.cpp)
};

// The job life cycle (lifecycle.cpp), guarded by Coordinator::mutex_ (Coordinator::Job::retention):
// when the job ended, whether its film was freed, and the pins that keep it alive while it is
// used outside the lock.
struct JobRetention {
  double endedUnixSeconds = 0.0;  // when it ended; 0 while it runs
  bool archived = false;          // `film` is freed; its image is in Coordinator's JobArchive
  bool archiving = false;         // archiveJob is writing its image (image() waits)
  bool deleting = false;          // deleteJob waits for the pins to go (no new pin is made)
  uint32_t pins = 0;              // Coordinator::JobPin's alive on this job

  // A new pin (Coordinator::JobPin): false, and no pin made, while the job is being deleted.
  bool pin() {
    if (deleting) return false;
    ++pins;
    return true;
  }
  // A pin let go: true if it was the last one (deleteJob and archiveJob wait for that).
  bool unpin() { return --pins == 0; }
  // archiveJob may free the film: no pin is left, so nothing reads it outside the lock.
  bool mayFreeFilm() const { return pins == 0; }
  // deleteJob may free the job: no archiving under way, and no pin left.
  bool mayDelete() const { return !archiving && pins == 0; }
  // The film is freed, or being freed (archiveJob is writing its image): no sensor to serve,
  // nothing left to archive.
  bool filmReleased() const { return archived || archiving; }
};

// One job: its records by concern, each guarded by Coordinator::mutex_ unless its comment says
// otherwise.
struct Coordinator::Job {
  JobDefinition definition;  // what it is, fixed at submission
  // Jobs are served by priority (higher first), then by submission order (definition.sequence).
  // Guarded by Coordinator::mutex_; it changes over the job's life (setPriority), read by
  // tryLease(), tryAuditLease() and jobs() on every call.
  int priority = 0;
  // Scheduling state (scheduling.cpp), guarded by Coordinator::mutex_ and persisted: paused
  // (pauseJob), approved (approveJob), and released: its dependencies held once, so it is
  // leased from then on whatever becomes of the jobs it waited for.
  bool paused = false;
  bool approved = false;
  bool released = false;
  bool brokenReported = false;  // a dependency that can no longer hold was said in an event
  bool prefetch = false;        // prefetchJob: workers fetch its assets ahead (not persisted)
  // Whether this job is served before `other` in listings, audits and backups (tryLease uses
  // leasedBefore, which adds fair share).
  bool servedBefore(const Job& other) const {
    return priority != other.priority ? priority > other.priority : definition.sequence < other.definition.sequence;
  }
  // The traversal kernel every unit is rendered with (util/trace_kernel.h; docs/farm.md "Mixed
  // machines"): the spec's `kernel`, else pinned when its first unit is leased (pinKernel) and
  // persisted. Empty until then.
  std::string kernel;
  // Whether `worker` may render its units: it can hold one, and runs the kernel.
  bool takes(const WorkerInfo& worker) const { return definition.fitsOn(worker) && runsKernel(worker.kernels, kernel); }
  JobProgress progress;  // its state, units and published progress
  // Failures reported by workers, the blocklist, and the workers gone holding its units
  // (job_failures.h); guarded by Coordinator::mutex_.
  JobFailures failures;
  JobAudit audit;                      // the cross-worker audit
  std::vector<JobInfo::Event> events;  // at most Coordinator::kMaxJobEvents, oldest first
  void addEvent(std::string text);

  // Accumulation: the sensor, tracker and stopping rules, behind the accumulator's own lock
  // (never held while taking Coordinator::mutex_). Set once, before the job is listed.
  std::unique_ptr<Accumulator> film;
  // The film's share of the coordinator's memory budget (the estimate less one image), held while
  // the film is; and, without a state dir, the archived image's encoded bytes.
  MemoryBudget::Reservation memory, archiveMemory;

  JobRetention retention;  // the job life cycle

  // Fixes the definition (and `progress.units`) from the job's scene, loaded with its overrides.
  void setScene(const Scene& scene) {
    definition.setScene(scene);
    progress.units = JobUnits(definition.layout.unitCount());
  }
};

}  // namespace lensfarm
