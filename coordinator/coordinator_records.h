#pragma once
// The coordinator's private records, shared by the files that implement Coordinator
// (coordinator.h lists them). Nothing outside coordinator/ includes this header; every field is
// guarded by Coordinator::mutex_ unless its comment says otherwise.
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/farm/job_layout.h"
#include "common/film/diffraction_psf.h"
#include "common/scene/scene.h"
#include "coordinator/accumulator.h"
#include "coordinator/audit.h"
#include "coordinator/coordinator.h"
#include "coordinator/job_failures.h"
#include "coordinator/job_units.h"

namespace lensfarm {

struct Coordinator::Job {
  std::string id;
  JobSpec spec;
  int priority = 0;
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
  // Fixes the above (and `units`) from the job's scene, loaded with its overrides.
  void setScene(const Scene& scene);

  // Scheduling, guarded by Coordinator::mutex_.
  JobState state = JobState::kQueued;
  std::string error;
  JobUnits units;  // to lease, being recorded, counted
  std::optional<Clock::time_point> started;
  std::optional<Clock::time_point> finished;
  std::map<std::string, uint64_t> unitsByWorker;  // provenance
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
  // Failures reported by workers, the blocklist, and the workers gone holding its units
  // (job_failures.h); guarded by Coordinator::mutex_.
  JobFailures failures;

  // The cross-worker audit (audit.h, auditing.cpp), guarded by Coordinator::mutex_: the units
  // under audit; who each counted unit from `trustedUnits` on came from and when it was accepted
  // (Coordinator's acceptance sequence), for a rewind; units [0, trustedUnits) were delivered
  // by workers that a later audit found right, and are never undone.
  AuditBook audits;
  struct Provenance {
    std::string worker;
    uint64_t seq = 0;
  };
  std::map<uint64_t, Provenance> provenance;
  uint64_t trustedUnits = 0;
  uint64_t generation = 0;  // the film's (Accumulator::generation): grows with every rewind
  // The stop the film reached while audits were pending: the job ends with it once they settle.
  std::optional<std::string> stopAwaitingAudits;
  uint64_t auditsPassed = 0, auditsFailed = 0, unitsRerendered = 0;
  std::vector<JobInfo::Event> events;  // at most Coordinator::kMaxJobEvents, oldest first
  void addEvent(std::string text);

  // Accumulation: the sensor, tracker and stopping rules, behind the accumulator's own lock
  // (never held while taking Coordinator::mutex_). Set once, before the job is listed.
  std::unique_ptr<Accumulator> film;

  // The job life cycle (lifecycle.cpp), guarded by Coordinator::mutex_.
  std::string owner;
  double endedUnixSeconds = 0.0;  // when it ended; 0 while it runs
  bool archived = false;          // `film` is freed; its image is in Coordinator's JobArchive
  bool archiving = false;         // archiveJob is writing its image (image() waits)
  bool deleting = false;          // deleteJob waits for the pins to go (no new pin is made)
  uint32_t pins = 0;              // Coordinator::JobPin's alive on this job
};

}  // namespace lensfarm
