#pragma once
// The coordinator's private records, shared by the files that implement Coordinator
// (coordinator.cpp: jobs, scheduling and accumulation; workers.cpp: workers, their liveness and
// why a job is stalled). Nothing outside coordinator/ includes this header; every field is
// guarded by Coordinator::mutex_ unless its comment says otherwise.
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "coordinator.h"
#include "scene/scene.h"

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
  uint64_t unitsTotal = 0;
  uint64_t unitMemoryBytes = 0;  // what one unit takes on a worker (workerJobMemory); leases skip smaller workers
  // Whether `worker` can hold one unit (WorkerInfo::maxUnitMemoryBytes; 0: it did not say).
  bool fitsOn(const WorkerInfo& worker) const {
    return worker.maxUnitMemoryBytes == 0 || unitMemoryBytes <= worker.maxUnitMemoryBytes;
  }
  std::vector<std::string> effects;  // what the renderer simulates for this job, and why

  // Scheduling, guarded by Coordinator::mutex_.
  JobState state = JobState::kQueued;
  std::string error;
  // Units to lease: every index from nextFresh on, plus those whose lease lapsed. Kept lazily so
  // that a job of 2^40 samples costs no more than a small one.
  uint64_t nextFresh = 0;
  std::set<uint64_t> returned;
  // Units whose result was accepted (counted once): all below receivedBelow, plus receivedAbove.
  uint64_t receivedBelow = 0;
  std::set<uint64_t> receivedAbove;

  bool hasPending() const { return !returned.empty() || nextFresh < unitsTotal; }
  uint64_t takePending() {
    if (!returned.empty()) {
      const uint64_t u = *returned.begin();
      returned.erase(returned.begin());
      return u;
    }
    return nextFresh++;
  }
  void clearPending() {
    returned.clear();
    nextFresh = unitsTotal;
  }
  std::set<uint64_t> inflight;  // accepted, being made durable before they count
  bool isReceived(uint64_t u) const { return u < receivedBelow || receivedAbove.count(u); }
  void markReceived(uint64_t u) {
    receivedAbove.insert(u);
    while (!receivedAbove.empty() && *receivedAbove.begin() == receivedBelow) {
      receivedAbove.erase(receivedAbove.begin());
      ++receivedBelow;
    }
  }
  std::optional<Clock::time_point> started;
  std::optional<Clock::time_point> finished;
  std::map<std::string, uint64_t> unitsByWorker;  // provenance
  uint64_t version = 1;
  // Published accumulation progress (copied from the accumulator under mutex_).
  uint64_t unitsAdded = 0;
  uint64_t samplesPerPixelDone = 0;
  PathStats stats;
  ErrorEstimate estimate;
  std::string stopReason;                // why a finished job stopped
  std::optional<uint64_t> stopUnits;     // a job stopped early keeps units [0, stopUnits)
  bool deadlinePassed = false;
  std::vector<ErrorPoint> history;  // guarded by Coordinator::mutex_; see recordEstimate()
  // The last worker lost (or gone) while holding units of this job, for stalledReason().
  struct Loss {
    std::string worker, verb, detail;  // "w1 (worker-3.1)", "lost", "connection closed"
    Clock::time_point when;
    std::vector<uint64_t> units;
  };
  std::optional<Loss> lastLoss;  // guarded by Coordinator::mutex_

  // Accumulation, guarded by `accumulate` (never held while taking Coordinator::mutex_).
  mutable std::mutex accumulate;
  std::unique_ptr<Sensor> sensor;
  std::map<uint64_t, UnitResult> arrived;  // results waiting for an earlier unit
  uint64_t nextToAdd = 0;
  uint64_t sppAdded = 0;
  PathStats statsAdded;
  uint64_t checkpointed = 0;  // units in the last saved sensor
  // Stopping rules (docs/accuracy.md), decided here so that the kept units are a prefix chosen
  // in unit order: the same units whatever order results arrive in, and after a restart.
  std::unique_ptr<ConvergenceTracker> tracker;
  ErrorEstimate estimateAdded;
  Clock::time_point estimatedAt;
  uint64_t foldLimit = std::numeric_limits<uint64_t>::max();  // units from here on are never folded
  bool stopAtNextFold = false;  // the deadline passed before the first unit was folded
  std::string stopReasonAdded;

  void stopFolding(std::string reason) {
    foldLimit = nextToAdd;
    stopReasonAdded = std::move(reason);
    arrived.clear();
  }
};

struct Coordinator::Worker {
  std::string id;
  WorkerInfo info;
  Clock::time_point lastHeartbeat;
  std::string currentJobId;
  uint64_t unitsDone = 0;
  std::optional<uint64_t> currentUnit;
  double samplesPerSecond = 0.0;
  // Liveness (attachWorker, workerLost, workerLeft).
  uint64_t attachment = 0;          // the Attach stream it holds; 0: none
  std::optional<WorkerState> gone;  // kLost or kLeft: its id is refused from then on
  Clock::time_point goneAt;
  std::string goneReason;
  std::string label() const { return info.name.empty() ? id : info.name + " (" + id + ")"; }
};

}  // namespace lensfarm
