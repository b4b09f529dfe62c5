#pragma once
// The worker's life: register, then lease a unit, make sure its job's scene is loaded (spec and
// assets fetched by hash, scene loaded and checked against the job's hash), trace the unit with
// the common renderer on this worker's threads, upload the partial sensor buffer, repeat.
// A heartbeat thread keeps the leases alive and cancels a unit whose lease was revoked.
// Network failures are retried with capped exponential backoff (never a busy loop); an
// unknown-worker answer (the coordinator restarted) makes the worker register again.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <tbb/task_arena.h>

#include "common/render/render_scene.h"
#include "worker/asset_cache.h"
#include "worker/coordinator_link.h"

namespace lensfarm {

struct WorkerOptions {
  std::string name;                // shown in `lensfarm workers`
  unsigned threads = 1;            // render threads
  double leaseWaitSeconds = 2.0;   // long-poll time per lease request
  double maxBackoffSeconds = 5.0;  // cap of the retry delay
  std::filesystem::path cacheDir;  // empty: assets cached in memory only
  // A unit whose estimated memory (farm/memory_estimate.h, workerJobMemory) exceeds this is
  // refused with a failure report; 0: no limit. lensfarm-worker: defaultJobMemoryBudget().
  uint64_t maxMemoryBytes = 0;
  // Leave the farm after this many seconds without a unit to render (a batch-scheduled worker
  // gives its allocation back when the farm has no work: deploy/slurm); 0: never.
  double idleExitSeconds = 0.0;
  // Its tags (farm/job_policy.h): jobs that require tags are leased only to workers with all of
  // them (docs/farm.md "Scheduling").
  std::vector<std::string> tags;
};

struct WorkerCounters {
  std::atomic<uint64_t> unitsRendered{0};
  std::atomic<uint64_t> unitsAccepted{0};
  std::atomic<uint64_t> unitsAbandoned{0};  // lease revoked or upload refused
  std::atomic<uint64_t> registrations{0};
};

class WorkerLoop {
 public:
  WorkerLoop(CoordinatorLink& link, WorkerOptions options);
  ~WorkerLoop();

  // Runs until stop() is called or, with idleExitSeconds, until no unit came for that long; the
  // unit in progress is finished and uploaded first unless stopNow() is called. Then it leaves
  // the farm cleanly: the coordinator queues the units of its leases again at once.
  void run();
  void stop();     // drain: finish the current unit, then return
  void stopNow();  // cancel the current unit and return

  const WorkerCounters& counters() const { return counters_; }
  const AssetCache& assets() const { return assets_; }

 private:
  struct PreparedJob {
    Scene scene;
    std::unique_ptr<RenderScene> renderScene;
    std::string kernel;  // the traversal kernel it renders with (UnitResult::kernel)
  };
  std::shared_ptr<PreparedJob> prepare(const LeaseGrant& grant);
  // Fetches the job's assets into the cache ahead of its units (LeaseWorkResponse.prefetch_job_id).
  void prefetch(const std::string& jobId);
  void registerNow();  // a new worker id from the coordinator
  // One leased unit: its job prepared, the unit traced on `arena` and delivered; a unit this
  // worker cannot render is reported (reportFailure), never left to lapse.
  void serve(const std::string& id, const LeaseGrant& grant, tbb::task_arena& arena);
  void deliver(const LeaseGrant& grant, const UnitResult& result);  // the upload, retried through outages
  void heartbeatLoop();
  void sleepFor(double seconds);  // interruptible by stop()
  std::string workerId();

  CoordinatorLink& link_;
  WorkerOptions options_;
  AssetCache assets_;
  WorkerCounters counters_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::string workerId_;
  double heartbeatInterval_ = 1.0;
  std::optional<uint64_t> currentLease_;
  // The unit of currentLease_ is traced and being uploaded: a revocation the heartbeat hears now
  // is the coordinator having taken the upload (the lease ends with it) or refusing it, which the
  // upload's own answer says; either way there is nothing left to cancel.
  bool uploading_ = false;  // guarded by mutex_
  std::atomic<bool> cancelUnit_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<bool> stopNow_{false};
  std::map<std::string, std::shared_ptr<PreparedJob>> jobs_;  // the few most recent, by "job@frame"
  std::deque<std::string> jobOrder_;                          // oldest first
  std::thread heartbeat_;
};

}  // namespace lensfarm
