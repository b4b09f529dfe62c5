#pragma once
// The coordinator's state and rules, with no network code: the job table, the unit scheduler
// and its leases, the asset store and the accumulation of results. The gRPC services
// (service.h) are thin translations onto this class; `lensfarm render` embeds it directly.
//
// Invariants:
//  - A job is a sequence of units (sample ranges over the whole frame, render/unit_renderer.h),
//    leased lowest index first, so early snapshots cover the whole frame.
//  - A unit's result is counted at most once, and only from the worker holding its current
//    lease; results enter the job's sensor in unit order (a later unit waits for the earlier
//    ones), so the image never depends on which worker finished first.
//  - Jobs are served by priority (higher first), then by submission order.
//  - A job stops when all its samples are in, or earlier at its target error or deadline
//    (RenderSettings): the image is then the prefix of units [0, k) for the first k that met
//    the rule (the deadline: the units folded when it passed, at least one), never a partial pass.
//  - With a state dir, a unit is acknowledged only once its sums and ledger row are durable
//    (state_store.h); a restarted coordinator resumes every job from its checkpoint plus the
//    ledger, and adds the rest in the same order, so the image is bitwise the same.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <thread>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "farm/farm_types.h"
#include "film/convergence.h"
#include "film/image_io.h"
#include "film/sensor.h"

namespace lensfarm {

enum class JobState { kQueued, kRunning, kDone, kCancelled, kFailed };
const char* jobStateName(JobState state);
inline bool isTerminal(JobState s) { return s == JobState::kDone || s == JobState::kCancelled || s == JobState::kFailed; }

// A job's status as of one moment.
struct JobInfo {
  std::string id;
  JobState state = JobState::kQueued;
  int priority = 0;
  std::string sceneName;
  std::string sceneHash;
  int width = 0, height = 0;
  uint64_t samplesPerPixelDone = 0, samplesPerPixelTotal = 0;
  uint64_t unitsDone = 0, unitsTotal = 0;
  PathStats stats;
  double elapsedSeconds = 0.0;
  double remainingSeconds = 0.0;
  uint32_t workersBusy = 0;
  std::string error;
  double submittedUnixSeconds = 0.0;
  uint64_t version = 0;  // grows with every change of the job
  std::vector<std::string> effects;  // "depth of field: off (aperture closed ...)", scene/effects.h
  // Convergence (film/convergence.h, docs/accuracy.md).
  double estimatedRelativeError = -1.0;  // estimated relative RMSE of the image; < 0 until known
  double targetError = 0.0;              // the job's target; 0 if none
  double secondsToTarget = 0.0;          // projected; 0 if unknown or reached
  double timeLimitSeconds = 0.0;         // the deadline after submission; 0 if none
  std::string stopReason;                // why a finished job stopped

  double raysPerSecond() const { return elapsedSeconds > 0 ? double(stats.rays) / elapsedSeconds : 0.0; }
  double lightHitFraction() const { return stats.paths ? double(stats.lightHits) / double(stats.paths) : 0.0; }
};

struct WorkerView {
  std::string id;
  WorkerInfo info;
  std::string currentJobId;
  uint64_t unitsDone = 0;
  double secondsSinceHeartbeat = 0.0;
  // For the dashboard: the unit it holds now (if any) and its speed on its last accepted unit.
  std::optional<uint64_t> currentUnit;
  double samplesPerSecond = 0.0;  // camera paths of its last accepted unit / its render seconds
};

// One point of a job's error-vs-time curve: the published estimate when it changed.
struct ErrorPoint {
  double elapsedSeconds = 0.0;
  double relativeError = 0.0;
  uint64_t samplesPerPixel = 0;
};

// The image of a job as it is now, and how to expose it.
struct JobImage {
  Image image;
  ImageMetadata metadata;
  ExposureSettings exposure;
};

// What the metrics endpoint shows (metrics.h renders it): counters since this process started,
// and jobs, workers and leases as they are at one moment.
struct MetricsSnapshot {
  uint64_t unitsLeased = 0;         // leases granted (a unit leased again after a lapse counts again)
  uint64_t unitsDone = 0;           // results accepted and counted, each unit once
  uint64_t unitsExpired = 0;        // leases that lapsed without a result
  uint64_t samples = 0;             // camera paths in the accepted results
  uint64_t unitBytesReceived = 0;   // result buffers (sums) received from workers
  uint64_t assetBytesReceived = 0;  // asset bytes uploaded by clients
  uint64_t leasesActive = 0;
  double leaseTimeoutSeconds = 0.0;
  std::vector<JobInfo> jobs;
  std::vector<WorkerView> workers;
};

class Coordinator {
 public:
  struct Options {
    double leaseTimeoutSeconds = 30.0;      // a lease lapses this long after the last heartbeat
    double heartbeatIntervalSeconds = 1.0;  // told to workers at registration
    std::filesystem::path stateDir;         // empty: state in memory only (lost on exit)
    double checkpointEverySeconds = 30.0;   // how often accumulated sensors are saved
    // Results that arrive ahead of an unfinished earlier unit wait in memory until it comes
    // (canonical order). Fresh units are leased at most this many bytes of buffers ahead of the
    // summed prefix, which bounds that memory however many workers there are.
    uint64_t maxBytesAhead = uint64_t(2) << 30;
  };
  explicit Coordinator(Options options);
  Coordinator();
  ~Coordinator();

  // ---- assets (content-addressed) ----
  bool hasAsset(const std::string& sha256) const;
  // Stores bytes under their hash; throws FarmError(kInvalidArgument) if they do not match it.
  // Returns false if the asset was already present.
  bool putAsset(const std::string& sha256, std::string bytes);
  std::shared_ptr<const std::string> asset(const std::string& sha256) const;

  // ---- jobs (client side) ----
  // Validates the scene with its overrides (InputError naming the field) and that every asset
  // was uploaded (FarmError kFailedPrecondition listing the missing ones).
  JobInfo submit(const JobSpec& spec, int priority);
  JobInfo job(const std::string& jobId) const;  // FarmError kNotFound
  std::vector<JobInfo> jobs() const;            // in serving order
  // Waits until the job's version exceeds `afterVersion` or `timeoutSeconds` pass.
  JobInfo waitForChange(const std::string& jobId, uint64_t afterVersion, double timeoutSeconds) const;
  JobInfo cancel(const std::string& jobId);
  JobImage image(const std::string& jobId) const;
  // The job's sensor in full precision (Sensor::serialize), as a checkpoint would save it.
  std::string sensorState(const std::string& jobId) const;
  std::vector<WorkerView> workers() const;

  // ---- dashboard (dashboard.h) ----
  // Sets a job's priority (persisted with a state dir); serving order follows at once.
  // FarmError kNotFound for an unknown job.
  JobInfo setPriority(const std::string& jobId, int priority);
  // The job's estimate each time it changed, oldest first; at most kMaxErrorPoints (when full,
  // every other point is dropped, so the curve keeps its whole span at half the density).
  static constexpr size_t kMaxErrorPoints = 512;
  std::vector<ErrorPoint> errorHistory(const std::string& jobId) const;

  // ---- workers ----
  // FarmError kFailedPrecondition naming both versions when they differ from this process's.
  std::string registerWorker(const WorkerInfo& info);
  // Extends the worker's leases; returns those it must drop. FarmError kNotFound if unknown.
  std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds);
  // The next unit to render, waiting up to `waitSeconds` for one.
  std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds);
  JobSpec jobSpec(const std::string& jobId) const;
  // Counts a unit's result. Returns false for a duplicate of a unit already counted (ignored);
  // FarmError kFailedPrecondition when the worker does not hold the unit's current lease.
  bool acceptResult(UnitResult result);
  void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId, const std::string& error);

  const Options& options() const { return options_; }

  // Saves every job's sensor now (also done every checkpointEverySeconds, when a job ends, and
  // on destruction). Without a state dir, does nothing. Returns the bytes written.
  uint64_t checkpoint();

  // ---- metrics ----
  MetricsSnapshot metricsSnapshot() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Job;
  struct Worker;
  struct ActiveLease {
    std::string workerId;
    std::string jobId;
    uint64_t unit;
    Clock::time_point deadline;
  };

  Job& findJob(const std::string& jobId) const;  // requires mutex_
  Worker& findWorker(const std::string& workerId);
  JobInfo infoOf(const Job& job) const;
  void reapExpiredLeases(Clock::time_point now);
  void revokeLeasesOf(Job& job);
  void touch(Job& job);
  std::optional<LeaseGrant> tryLease(Worker& worker, Clock::time_point now);
  void drainInOrder(Job& job);  // requires job.accumulate
  void finish(Job& job, const std::string& reason);  // requires mutex_
  void enforceDeadlines();                           // requires mutex_
  void restore();
  void persistState(const Job& job);  // requires mutex_
  void checkpointLoop();

  Options options_;
  std::unique_ptr<class StateStore> store_;
  uint64_t epoch_ = 0;  // distinguishes ids issued by this run from those of earlier runs
  std::thread checkpointer_;
  std::condition_variable checkpointWake_;
  bool stopping_ = false;  // guarded by mutex_
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;  // any job changed, or work became available
  std::map<std::string, std::shared_ptr<const std::string>> assets_;
  std::map<std::string, std::unique_ptr<Job>> jobs_;
  std::map<std::string, std::unique_ptr<Worker>> workers_;
  std::map<uint64_t, ActiveLease> leases_;
  uint64_t nextJob_ = 1, nextWorker_ = 1, nextLease_ = 1, nextSequence_ = 1;

  // Counted for metricsSnapshot() since this process started.
  struct Counters {
    std::atomic<uint64_t> unitsLeased{0}, unitsDone{0}, unitsExpired{0}, samples{0}, unitBytes{0}, assetBytes{0};
  };
  Counters counters_;
};

}  // namespace lensfarm
