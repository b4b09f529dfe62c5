#pragma once
// The coordinator's state and rules, with no network code: the job table, the unit scheduler
// and its leases, the asset store and the accumulation of results. The gRPC services
// (service.h) are thin translations onto this class; `lensfarm render` embeds it directly.
//
// Coordinator composes plain classes that each own one concern's state: AssetStore
// (asset_store.h), LeaseTable (lease_table.h), and per job JobUnits (job_units.h) and an
// Accumulator (accumulator.h). Its own members are implemented by concern: coordinator.cpp (the
// job table and each job's life), scheduler.cpp (leases: granting, extending, expiry, revoking),
// results.cpp (accepting results and failures, publishing progress, stopping at deadlines),
// persistence.cpp (checkpoints and restoring from the state dir) and workers.cpp (workers and
// their liveness, and why a job is stalled).
//
// Invariants:
//  - A job is a sequence of units (sample ranges over the whole frame, render/unit_renderer.h),
//    leased lowest index first, so early snapshots cover the whole frame.
//  - A unit's result is counted at most once, and only from the worker holding its current
//    lease; results enter the job's sensor in unit order (a later unit waits for the earlier
//    ones), so the image never depends on which worker finished first.
//  - Jobs are served by priority (higher first), then by submission order.
//  - A worker whose Attach stream breaks is lost at once (workerLost): its leases are revoked and
//    their units queued again, so an upload under one is refused and each unit still counts once.
//  - A job stops when all its samples are in, or earlier at its target error or deadline
//    (RenderSettings): the image is then the prefix of units [0, k) for the first k that met
//    the rule (the deadline: the units folded when it passed, at least one), never a partial pass.
//  - With a state dir, a unit is acknowledged only once its sums and ledger row are durable
//    (state_store.h); a restarted coordinator resumes every job from its checkpoint plus the
//    ledger, and adds the rest in the same order, so the image is bitwise the same.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/farm/farm_types.h"
#include "common/farm/job_policy.h"
#include "common/film/convergence.h"
#include "common/film/image_io.h"
#include "common/film/sensor.h"
#include "common/util/memory_budget.h"
#include "coordinator/core/audit.h"
#include "coordinator/core/event_feed.h"
#include "coordinator/core/fair_share.h"
#include "coordinator/core/lease_table.h"
#include "coordinator/core/locking.h"
#include "coordinator/core/worker_registry.h"
#include "coordinator/store/asset_store.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

enum class JobState { kQueued, kRunning, kDone, kCancelled, kFailed };
const char* jobStateName(JobState state);
inline bool isTerminal(JobState s) {
  return s == JobState::kDone || s == JobState::kCancelled || s == JobState::kFailed;
}

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
  uint64_t version = 0;              // grows with every change of the job
  std::vector<std::string> effects;  // "depth of field: off (aperture closed ...)", scene/effects.h
  std::string kernel;                // its traversal kernel (util/trace_kernel.h); empty until pinned
  std::vector<std::string> builds;   // "BUILD (KERNEL): N units", one per build that rendered units
  // Convergence (film/convergence.h, docs/accuracy.md).
  double estimatedRelativeError = -1.0;  // estimated relative RMSE of the image; < 0 until known
  double targetError = 0.0;              // the job's target; 0 if none
  double secondsToTarget = 0.0;          // projected; 0 if unknown or reached
  double timeLimitSeconds = 0.0;         // the deadline after submission; 0 if none
  std::string stopReason;                // why a finished job stopped
  // Why no worker renders the job now ("no workers connected", "worker w1 (worker-3.1) lost 2 s
  // ago (connection closed); unit 5 queued again; waiting for a worker ..."); empty while it is
  // rendered or finished. See Coordinator::stalledReason.
  std::string stalledReason;
  // How far the job is toward its stop, 0 to 1: the nearest of its samples (with a cap of its
  // own), its target error ((target / estimate)^2) and its deadline; 1 when done.
  double progressFraction = 0.0;
  // The cross-worker audit (docs/farm.md "Audit"): units of this job rendered again by another
  // worker and compared with the counted result.
  uint64_t auditsPassed = 0;     // agreed within Options::auditTolerance
  uint64_t auditsFailed = 0;     // disagreed, and a third worker said which one was wrong
  uint64_t auditsExplained = 0;  // disagreed as two builds' rounding does: nobody was wrong
  uint64_t auditsPending = 0;    // waiting for a worker to render them again
  uint64_t unitsRerendered = 0;  // counted units queued again because a wrong worker was found
  // What happened to the job that a person watching it should know: audits that failed, workers
  // quarantined, units queued again. Oldest first, at most kMaxJobEvents (the oldest dropped).
  struct Event {
    double unixSeconds = 0.0;
    std::string text;
  };
  std::vector<Event> events;
  // How the job is cut into units (farm/job_layout.h, docs/farm.md "Tiles and passes"): 0 for
  // passes over the whole frame, else the tile edge; and, for an animation, each frame's state.
  int tileSize = 0;
  uint64_t tilesPerFrame = 0;  // 0 for passes
  struct Frame {
    int64_t number = 0;      // the scene frame
    uint64_t tilesDone = 0;  // of tilesPerFrame
    bool complete() const { return tilesDone > 0 && tilesDone == tilesTotal; }
    uint64_t tilesTotal = 0;
  };
  std::vector<Frame> frames;  // empty for a still
  // The job life cycle (docs/farm.md "Job life cycle").
  std::string owner;              // who submitted it (SubmitJobRequest.owner: the client's $USER or --owner)
  double endedUnixSeconds = 0.0;  // when it ended (done, cancelled, failed); 0 while it runs
  bool archived = false;          // its film was freed; its final image, status and events stay readable
  // Scheduling (docs/farm.md "Scheduling", scheduling.cpp).
  JobPolicy policy;                     // as submitted
  bool paused = false;                  // pauseJob: nothing of it is leased until resumeJob
  bool approved = false;                // approveJob: what "JOB:approved" dependencies wait for
  std::vector<std::string> waitingFor;  // its dependencies that do not hold yet, one line each
  // A job with a target error and a deadline: whether the farm can reach the target in time, e.g.
  // "on track: about 40 s of the farm's 2 workers needed, 120 s left"; empty otherwise.
  std::string deadlineOutlook;
  bool prefetch = false;  // prefetchJob: workers fetch its assets ahead

  double raysPerSecond() const { return elapsedSeconds > 0 ? double(stats.rays) / elapsedSeconds : 0.0; }
  double lightHitFraction() const { return stats.paths ? double(stats.lightHits) / double(stats.paths) : 0.0; }
};

// JobInfo::progressFraction: the nearest of the job's stopping rules, 0 to 1.
double progressFraction(const JobInfo& info, double nowUnixSeconds);

// A duration flag ("7d", "12h", "30m", "3600s", "90", "0.2s"; a bare number is seconds) in
// seconds (lifecycle.cpp). InputError naming `flag` for anything else, or a negative duration.
double parseDuration(const std::string& text, const std::string& flag);

struct WorkerView {
  std::string id;
  WorkerInfo info;
  std::string currentJobId;
  uint64_t unitsDone = 0;
  double secondsSinceHeartbeat = 0.0;
  // For the dashboard: the unit it holds now (if any) and its speed on its last accepted unit.
  std::optional<uint64_t> currentUnit;
  double samplesPerSecond = 0.0;  // camera paths of its last accepted unit / its render seconds
  WorkerState state = WorkerState::kIdle;
  double secondsInState = 0.0;               // lost or left: since then; stale: since last heard from
  std::string stateReason;                   // lost: why, and what was queued again
  bool attached = false;                     // holds an Attach stream, so a broken connection is seen at once
  uint64_t failures = 0;                     // units it reported failed (ReportFailure)
  std::vector<std::string> blocklistedJobs;  // jobs it is no longer leased (docs/farm.md "Failures")
  // The cross-worker audit (docs/farm.md "Audit"): a quarantined worker returned a result that
  // another two workers disagreed with; it is leased nothing more until the coordinator restarts.
  uint64_t auditsPassed = 0;    // its own counted units an audit confirmed
  uint64_t auditsRendered = 0;  // audits it rendered for another worker's units, which agreed
  uint64_t registrations = 1;   // of its credential (info.credential), this run
  bool quarantined = false;
  std::string quarantineReason;  // "unit 12 of job-3: sums differ from w2 and w4 by up to 1.0e-03 (cell 4711)"
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
  MemoryBudget::Reservation memory;  // the image's share of the coordinator's budget, while it lives
};

// What the metrics endpoint shows (metrics.h renders it): counters since this process started,
// and jobs, workers and leases as they are at one moment.
struct MetricsSnapshot {
  uint64_t unitsLeased = 0;            // leases granted (a unit leased again after a lapse counts again)
  uint64_t backupLeases = 0;           // of those, backups of a unit leased to a much slower worker
  uint64_t unitsDone = 0;              // results accepted and counted, each unit once
  uint64_t unitsExpired = 0;           // leases that lapsed without a result
  uint64_t workersLost = 0;            // workers marked lost when their Attach stream broke
  uint64_t stateWriteFailures = 0;     // writes the state dir refused (a full disk, a quota, an I/O error)
  bool stateWritesStalled = false;     // leasing paused until the state dir takes writes again
  uint64_t auditsPassed = 0;           // audits whose two results agreed
  uint64_t auditsFailed = 0;           // audits that found a wrong worker
  uint64_t auditsExplained = 0;        // disagreements explained by the workers' builds
  uint64_t unitsRerendered = 0;        // counted units queued again after a wrong worker was found
  uint64_t samples = 0;                // camera paths in the accepted results
  uint64_t unitBytesReceived = 0;      // result buffers (sums) received from workers, as doubles (decoded)
  uint64_t unitWireBytesReceived = 0;  // the same uploads' sums as sent over gRPC (compressed or not)
  uint64_t assetBytesReceived = 0;     // asset bytes uploaded by clients (read in full)
  uint64_t assetUploadsStored = 0;     // uploads of assets new to the coordinator
  uint64_t assetUploadsPresent = 0;    // uploads of assets it held already (a client that asks first makes none)
  uint64_t assetsSent = 0;             // assets sent to workers (each worker fetches one once)
  uint64_t assetBytesResident = 0;     // asset bytes in memory now (with a state dir: those in use)
  uint64_t assetBytesStored = 0;       // asset bytes kept, in memory or on disk
  uint64_t assetsCollected = 0;        // assets removed by the garbage collection (collectAssets)
  uint64_t memoryBudgetBytes = 0;      // Options::memoryBudgetBytes
  uint64_t memoryReservedBytes = 0;    // reserved from it now: jobs, images, assets and archives in memory
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
    // The memory one job may take (farm/memory_estimate.h, coordinatorJobMemory): submit
    // refuses a bigger job (FarmError kResourceExhausted naming the estimate and this limit).
    // 0: defaultJobMemoryBudget() (LENSFARM_MAX_JOB_MEMORY, else 3/4 of the machine's memory).
    uint64_t maxJobMemoryBytes = 0;
    std::string maxJobMemorySource;  // for messages, e.g. "--max-job-memory"; empty: the default's
    // The memory all jobs, images and (without a state dir) assets and archived images may take
    // together (util/memory_budget.h, docs/farm.md "Memory"): a job that does not fit beside the
    // others is refused (kResourceExhausted naming what holds the budget), a download waits
    // up to imageWaitSeconds for room. 0: defaultJobMemoryBudget(), as for one job.
    uint64_t memoryBudgetBytes = 0;
    std::string memoryBudgetSource;  // for messages, e.g. "--memory-budget"
    double imageWaitSeconds = 30.0;
    // Jobs one owner (JobSpec's owner label) may have queued or running at once: a submit past it
    // is refused (kResourceExhausted), so one script in a loop cannot fill the queue. 0: no cap.
    uint32_t maxJobsPerOwner = 1000;
    // The most bytes of uploaded assets kept, in memory or on disk (AssetStore::setQuota); 0: no limit.
    uint64_t maxAssetBytes = 0;
    // The longest a lease may be held, however often it is extended: a worker that heartbeats
    // without ever uploading loses its unit after this (LeaseTable's longest end).
    double maxLeaseSeconds = 3600.0;
    // Failures (ReportFailure, docs/farm.md "Failures"): a worker that failed a job this many
    // times is not leased its units again (the job's blocklist); a job fails when one unit has
    // failed on this many different workers, or when every live worker is blocklisted for it.
    uint32_t maxFailuresPerWorker = 3;
    uint32_t maxUnitFailures = 3;
    // The cross-worker audit (docs/farm.md "Audit"): this fraction of counted units (and each
    // worker's first) is rendered again by another worker; results that differ by more than
    // auditTolerance (relative, per cell and channel) are settled by a third worker, and the
    // wrong one is quarantined. 0 turns the audit off.
    double auditFraction = 0.02;
    double auditTolerance = 1e-6;
    // A job with every unit in waits at most this long for its audits to be taken: past it, an
    // audit no worker has leased is waived with an event (a worker that heartbeats but never asks
    // for work, the only one that could render it, must not hold the job).
    double auditWaitSeconds = 60.0;
    // Test-only: called with a job's estimated bytes just before its frame-sized buffers are
    // allocated; a test throws std::bad_alloc from it to simulate an allocation failing.
    std::function<void(uint64_t bytes)> beforeJobAllocation;
    // The job life cycle (lifecycle.cpp, docs/farm.md "Job life cycle"): a job that ended more
    // than keepSeconds ago is deleted (0: kept forever); one that ended archiveAfterSeconds ago
    // is archived (0: at once; < 0: never). Checked every few seconds and at start-up.
    double keepSeconds = 0.0;
    double archiveAfterSeconds = -1.0;
    // Asset garbage collection (lifecycle.cpp, docs/farm.md "Assets"): an asset no job refers to
    // (archived jobs count; a deleted job does not) is removed once it has been unreferenced this
    // long (uploaded and never submitted, or its last job deleted); < 0: assets are kept forever.
    double assetGraceSeconds = 3600.0;
    // Quotas per owner at submission (kResourceExhausted naming the owner; 0: none): the bytes of
    // the distinct assets their jobs refer to, and the pixel-samples their queued and running
    // jobs have still to render.
    uint64_t maxAssetBytesPerOwner = 0;
    uint64_t maxSamplesPerOwner = 0;
    // Scheduling (docs/farm.md "Scheduling"): jobs of one priority share the farm between their
    // owners by weight (fair_share.h; an owner not listed weighs 1), or are served in submission
    // order (kFifo, the farm before fair share). Higher priorities always come first.
    enum class Sharing { kFairShare, kFifo };
    Sharing sharing = Sharing::kFairShare;
    std::map<std::string, double> ownerWeights;
  };
  explicit Coordinator(Options options);
  Coordinator();
  ~Coordinator();

  // ---- assets (content-addressed) ----
  bool hasAsset(const std::string& sha256) const;
  // The most hashes one missingAssets call takes (FindMissingAssets: 50000 hashes are ~3.3 MB,
  // within gRPC's 4 MiB message limit).
  static constexpr size_t kMaxAssetQuery = AssetStore::kMaxQuery;
  // Those of `sha256s` whose assets are not stored, in their order, each once: what a client
  // must upload before submitting. FarmError(kInvalidArgument) for more than kMaxAssetQuery
  // hashes, or naming the first that is not 64 lowercase hex digits by its index ("sha256[3]").
  std::vector<std::string> missingAssets(const std::vector<std::string>& sha256s) const;
  // Stores bytes under their hash; throws FarmError(kInvalidArgument) if they do not match it.
  // Returns false if the asset was already present.
  bool putAsset(const std::string& sha256, std::string bytes);
  // An upload of `sha256` has begun (its first message): true if the asset is stored already, so
  // the rest need not be read. Counted like a putAsset that found it present.
  bool uploadFindsAssetPresent(const std::string& sha256);
  // An upload of `bytes` (its declared size) begins: the asset quota is checked and the bytes it
  // will hold while it arrives are reserved from the memory budget (waiting up to
  // imageWaitSeconds), FarmError kResourceExhausted naming what is full otherwise.
  MemoryBudget::Reservation admitAssetUpload(const std::string& sha256, uint64_t bytes);
  // An asset's bytes for a worker (FetchAsset; counted in MetricsSnapshot::assetsSent).
  // FarmError(kNotFound) if it is not stored.
  std::shared_ptr<const std::string> asset(const std::string& sha256);

  // ---- jobs (client side) ----
  // Validates the scene with its overrides (InputError naming the field) and that every asset
  // was uploaded (FarmError kFailedPrecondition listing the missing ones).
  // `policy` (farm/job_policy.h): FarmError kInvalidArgument naming its field (checkPolicy),
  // kNotFound naming a job it waits for that does not exist. `paused`: submitted paused (pauseJob).
  JobInfo submit(const JobSpec& spec, int priority, const std::string& owner = "", const JobPolicy& policy = {},
                 bool paused = false);
  JobInfo job(const std::string& jobId) const;  // FarmError kNotFound
  std::vector<JobInfo> jobs() const;            // in serving order
  // Waits until the job's version exceeds `afterVersion` or `timeoutSeconds` pass.
  JobInfo waitForChange(const std::string& jobId, uint64_t afterVersion, double timeoutSeconds) const;
  JobInfo cancel(const std::string& jobId);
  // The image of the job's frame `frame` (a scene frame number of its range; nullopt: a still's
  // one image, or an animation's first frame). FarmError kNotFound for a frame outside the range,
  // kFailedPrecondition for an animation frame not rendered yet.
  JobImage image(const std::string& jobId, std::optional<int64_t> frame = std::nullopt) const;
  // An archived still's EXR as stored (with a state dir), opened, with its `size`: Download streams
  // it as it is, developing nothing. Null when there is none (not archived, an animation, no state
  // dir). FarmError kNotFound for an unknown job.
  std::unique_ptr<std::istream> archivedExr(const std::string& jobId, uint64_t* size) const;
  // Where a download's EXR is spooled when it is too large to encode in memory: the state dir, or
  // the system's temp dir without one.
  std::filesystem::path spoolDirectory() const;
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
  // The most events a job keeps (JobInfo::events).
  static constexpr size_t kMaxJobEvents = 64;
  std::vector<ErrorPoint> errorHistory(const std::string& jobId) const;

  // ---- scheduling (scheduling.cpp, docs/farm.md "Scheduling") ----
  // Pause: no unit (nor audit, nor backup) of the job is leased until resumeJob; leases held go
  // on, and their results count. Durable with a state dir. FarmError kNotFound for an unknown job,
  // kFailedPrecondition for one that has ended; pausing a paused job changes nothing.
  JobInfo pauseJob(const std::string& jobId);
  JobInfo resumeJob(const std::string& jobId);
  // A person approved the job: dependencies "JOB:approved" hold from now on. Durable.
  JobInfo approveJob(const std::string& jobId);
  // Changes a running job's priority, worker cap and share weight (each only when given), as
  // submit --priority, --max-workers and --share-weight would have: serving order and caps follow
  // at once. FarmError kInvalidArgument naming the field (a cap of 0, a weight outside (0, 1000]).
  struct JobUpdate {
    std::optional<int> priority;
    std::optional<uint32_t> maxWorkers;
    std::optional<double> shareWeight;
  };
  JobInfo updateJob(const std::string& jobId, const JobUpdate& update);
  // Prefetch: the connected workers that may render the job (its required tags) are asked, each
  // once, to fetch its assets into their caches now (takePrefetch), so a job that waits (paused,
  // dependencies, a busy farm) starts without a transfer. FarmError kNotFound for an unknown job,
  // kFailedPrecondition for one that has ended. Returns the job's status.
  JobInfo prefetchJob(const std::string& jobId);
  // A job whose assets the worker should fetch now (and may, without a lease: jobSpecFor,
  // assetFor), each job once per worker; "" if none. lease() returns early when there is one.
  std::string takePrefetch(const std::string& workerId);

  // The farm's notifications (event_feed.h): ListEvents, the HTTP API's event stream, webhooks.
  // With a state dir they are kept, and so is each webhook URL's progress (webhooks.h).
  const EventFeed& events() const { return events_; }
  std::optional<uint64_t> webhookCursor(const std::string& url) const;
  void setWebhookCursor(const std::string& url, uint64_t sequence);

  // ---- workers ----
  // FarmError kFailedPrecondition naming both versions when they differ from this process's.
  // `session`, if given, receives the worker's secret (256 random bits, hex): the gRPC service
  // requires it with the id on every later call (authenticateWorker).
  std::string registerWorker(const WorkerInfo& info, std::string* session = nullptr);
  // Whether the caller is the worker it names: FarmError kUnknownWorker if the id is unknown
  // (it registers again), kUnauthenticated without a session, kPermissionDenied with another's.
  void authenticateWorker(const std::string& workerId, const std::string& session);
  // Extends the worker's leases; returns those it must drop. FarmError kNotFound if unknown.
  std::vector<uint64_t> heartbeat(const std::string& workerId, const std::vector<uint64_t>& leaseIds);
  // The next unit to render, waiting up to `waitSeconds` for one.
  std::optional<LeaseGrant> lease(const std::string& workerId, double waitSeconds);
  JobSpec jobSpec(const std::string& jobId) const;
  // The same for a worker over the network: only for a job it holds a lease of, and only an
  // asset of such a job (FarmError kFailedPrecondition otherwise, naming what it lacks).
  JobSpec jobSpecFor(const std::string& workerId, const std::string& jobId) const;
  std::shared_ptr<const std::string> assetFor(const std::string& workerId, const std::string& sha256);
  // Counts a unit's result. Returns false for a duplicate of a unit already counted (ignored);
  // FarmError kFailedPrecondition when the worker does not hold the unit's current lease.
  // A result that is the next unit in order is summed straight from the caller's buffer; one
  // that must wait for an earlier unit is kept (moved from an rvalue, copied from an lvalue). If
  // memory runs out holding it, the job fails (FarmError kResourceExhausted); others go on.
  bool acceptResult(UnitResult&& result);
  bool acceptResult(const UnitResult& result);
  // Counts the bytes of sums an upload sent over the wire (MetricsSnapshot::unitWireBytesReceived;
  // acceptResult counts the decoded ones).
  void countUnitWireBytes(uint64_t bytes) { counters_.unitWireBytes += bytes; }
  // Before an upload's sums are read (UploadResult's header): the errors acceptResult would
  // give for its lease and frame size, so that no buffer is allocated for a refused upload.
  // `channels`: the sums a cell the upload carries (3 and the job's AOVs').
  void admitUpload(const std::string& workerId, uint64_t leaseId, const std::string& jobId, uint64_t unit, int width,
                   int height, int channels = 3) const;
  // The worker cannot render its lease's unit: the lease ends and the unit is queued again for
  // others; the worker is blocklisted for the job after Options::maxFailuresPerWorker failures;
  // the job fails, with the reasons, when the unit failed on Options::maxUnitFailures different
  // workers or no live worker may take it. FarmError kFailedPrecondition, changing nothing, when
  // the worker does not hold the lease or the lease is not for `jobId`.
  void reportFailure(const std::string& workerId, uint64_t leaseId, const std::string& jobId, const std::string& error);

  // ---- liveness (the Attach stream, docs/farm.md "Failures") ----
  // The worker now holds a stream whose end means it is gone; returns the attachment's id (a
  // newer attachment supersedes an older one). FarmError kUnknownWorker if unknown or lost.
  uint64_t attachWorker(const std::string& workerId);
  // The worker's connection broke: it is lost at once, not after the lease timeout. Its leases
  // are revoked and their units queued again (leased again before fresh ones), so a late upload
  // under one is refused (kFailedPrecondition) and each unit is still counted once; its id is
  // refused from now on (kUnknownWorker: a worker that is in fact alive registers again), and it
  // stays listed as lost with `reason` until forgotten. `attachment`: the stream that broke (a
  // superseded one changes nothing); 0: whatever the worker holds. Returns whether it was lost now.
  bool workerLost(const std::string& workerId, const std::string& reason, uint64_t attachment = 0);
  // The worker is stopping cleanly: listed as left; anything it still holds is queued again.
  void workerLeft(const std::string& workerId, uint64_t attachment = 0);

  const Options& options() const { return options_; }

  // ---- the job life cycle (lifecycle.cpp, docs/farm.md "Job life cycle") ----
  // Which jobs ListJobs returns: every condition given must hold.
  struct JobFilter {
    std::set<JobState> states;  // empty: any
    std::string owner;          // empty: anyone's
    std::string nameContains;   // a substring of the scene name; empty: any
    size_t limit = 0;           // at most this many, in serving order; 0: all
  };
  std::vector<JobInfo> jobs(const JobFilter& filter) const;
  // Removes a job for good: its leases revoked, its rows (job, ledger) and its files under the
  // state dir removed, its memory freed; a restart does not bring it back, and an upload under
  // one of its leases is refused (kFailedPrecondition). A job that has not ended is refused
  // (kFailedPrecondition) unless `force`, which cancels it first. kNotFound for an unknown id.
  void deleteJob(const std::string& jobId, bool force = false);
  // Keeps an ended job's final image (JobArchive) and frees everything else it holds: the
  // Accumulator (sensor, tracker, waiting results), its ledger rows, unit files and checkpoint.
  // Its status, events and image stay readable. kFailedPrecondition for a job that has not ended;
  // archiving an archived job changes nothing.
  JobInfo archiveJob(const std::string& jobId);
  // Removes the assets unreferenced for Options::assetGraceSeconds (also done every few
  // seconds); returns how many.
  size_t collectAssets();
  // Applies Options::keepSeconds and archiveAfterSeconds now (also done every few seconds).
  void applyRetention();

  // Saves every job's sensor now (also done every checkpointEverySeconds, when a job ends, and
  // on destruction). Without a state dir, does nothing. Returns the bytes written.
  uint64_t checkpoint();

  // ---- metrics ----
  MetricsSnapshot metricsSnapshot() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Job;
  using Worker = WorkerRecord;

  // ---- the job table (coordinator.cpp) ----
  Job& findJob(const std::string& jobId) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // findJob, once the job is not being archived (waiting on `lock`, of mutex_, meanwhile).
  Job& findJobNotArchiving(MutexLock& lock, const std::string& jobId) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  JobInfo infoOf(const Job& job) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);       // walks the leases and workers (stalledReason)
  static double elapsedSecondsOf(const Job& job);  // since its first lease, to its end or now
  void touch(Job& job) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void finish(Job& job, const std::string& reason) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Ends a job that has not ended: its state, its end time, its leases revoked
  // and its units no longer leased, the state persisted.
  void end(Job& job, JobState state) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  // ---- leases (scheduler.cpp) ----
  std::optional<LeaseGrant> tryLease(Worker& worker, Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  Clock::time_point leaseDeadline(Clock::time_point now) const;  // a lease granted or extended at `now`
  void reapExpiredLeases(Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Revokes the worker's leases and queues their units again; for messages,
  // "unit 5 queued again" or "" when it held nothing.
  // `verb` and `detail` say what happened ("lost", "connection closed").
  std::string releaseLeasesOf(Worker& worker, const std::string& verb, const std::string& detail, Clock::time_point now)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void revokeLeasesOf(Job& job) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  // ---- results and stopping (results.cpp) ----
  bool accept(const UnitResult& result, UnitResult* owned) ABSL_LOCKS_EXCLUDED(mutex_);
  // FarmError kInvalidArgument unless the result is one the unit can produce (results.cpp).
  // `map`: an adaptive unit's samples (film/sample_map.h), whose counts then replace sampleCount.
  // `maxRaysPerPath`: the job's (render/unit_renderer.h).
  static void checkPlausible(const UnitResult& result, uint64_t cells, uint32_t sampleCount, const AovLayout& aovs,
                             const SampleMap* map, uint64_t maxRaysPerPath);
  // Unit `unit` of `job` as a lease carries it: an adaptive unit with its map.
  // `ready` (if given) is false for a unit of a round not allocated yet (no map: not to be leased).
  WorkUnit unitToLease(const Job& job, uint64_t unit, bool* ready = nullptr) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // The grant of lease `leaseId` of `unit` of `job` (which carries the job's kernel).
  LeaseGrant grantOf(const Job& job, uint64_t leaseId, WorkUnit unit) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A backup lease for an idle `worker` of a unit still leased to a much slower one, near a job's
  // end (docs/farm.md "Slow machines"); nullopt when no backup would save time.
  std::optional<LeaseGrant> tryBackupLease(Worker& worker, Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // How long `worker` is expected to take for `unit` of `job`, from its measured samples per
  // second; -1 when not known yet.
  double expectedUnitSeconds(const Job& job, uint64_t unit, const Worker& worker) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A backup is leased only when it is expected to finish this many of its own unit times before
  // the straggler would: a backup costs a unit's work, so it must save more than that.
  static constexpr double kBackupMargin = 1.5;
  // Pins `job`'s traversal kernel as its first unit goes to `worker` (docs/farm.md "Mixed
  // machines"): the widest every connected worker that can hold a unit runs.
  void pinKernel(Job& job, const Worker& worker) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void enforceDeadlines() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  // ---- the cross-worker audit (auditing.cpp, docs/farm.md "Audit"); all but acceptAudit
  // require mutex_ ----
  // Whether `worker`'s counted unit of `job` is audited: its first one, then Options::auditFraction
  // of them, when another worker could render it.
  bool chooseForAudit(const Job& job, Worker& worker) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // An audit lease for `worker`, if a job it may render has a unit under audit it did not render.
  std::optional<LeaseGrant> tryAuditLease(Worker& worker, Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A result uploaded under an audit lease (after checkPlausible; takes mutex_ itself, and
  // compares the sums outside it).
  bool acceptAudit(const UnitResult& result);
  // `rounding`: the result's differences look like two machines' rounding (differenceLooksLikeRounding).
  void applyVerdict(Job& job, const AuditBook::Verdict& verdict, bool rounding) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A worker's build and whether it said its kernel: what an audit compares before it calls a
  // disagreement wrong (docs/farm.md "Mixed machines").
  std::string buildOf(const std::string& workerId) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void quarantine(Worker& worker, const std::string& reason) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Undoes `workerId`'s units of `job` since its last agreeing audit (and the units summed after
  // the rewind point before them), to render again.
  void rewindFor(Job& job, const std::string& workerId) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void updateTrust(Job& job) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);  // moves trustedUnits on after an audit agreed
  // A job whose film reached its stop ends once its audits are settled, or cannot be (no worker left to render them).
  void settleWaitingJobs() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  bool mayAudit(const Job& job, const Worker& worker, const std::string& exceptWorker = "") const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  // ---- the job life cycle (lifecycle.cpp) ----
  // Keeps a job (and its film) alive while it is used outside mutex_: deleteJob and archiveJob
  // wait until no pin is left. Made under mutex_ (kFailedPrecondition for a job being deleted);
  // its destructor takes mutex_, so it must outlive any lock_guard of mutex_ in its scope.
  class JobPin {
   public:
    JobPin() = default;
    JobPin(const Coordinator& coordinator, Job& job);
    JobPin(JobPin&& other) noexcept;
    JobPin& operator=(JobPin&& other) noexcept;
    ~JobPin();

   private:
    void release();
    const Coordinator* coordinator_ = nullptr;
    Job* job_ = nullptr;
  };

  // ---- results (results.cpp), continued ----
  // The steps of accept. checkProducible: FarmError kInvalidArgument for sums or counters the unit
  // cannot produce (checkPlausible), outside the lock. admit: the unit exists, its lease is held
  // and its shape is the unit's; the unit is then being recorded. record: the ledger row and sums,
  // durable (the unit queued again if that fails). count: the unit counted, its audit opened;
  // false when a rewind or a quarantine meanwhile means it is rendered again. sumAndPublish: the
  // sums added to the film (outside the lock), its progress published and a stop applied
  // (kResourceExhausted if the film could not keep them).
  struct Admission {
    Job* job = nullptr;
    JobPin pin;  // the job is neither deleted nor archived while its result is summed
    std::string workerName;
    std::string build;        // the worker's build and the result's kernel (LedgerEntry::build)
    uint64_t generation = 0;  // the film's, at admission
    bool duplicate = false;   // the unit is already counted or being counted: ignored
    bool auditLease = false;  // the upload renders a counted unit again (auditing.cpp)
    bool audited = false;     // chosen for audit: its sums are kept to compare
  };
  void checkProducible(const UnitResult& result) ABSL_LOCKS_EXCLUDED(mutex_);
  // A failure of `unit` of `job` on `worker` (reported, or its unit time limit passed): counted
  // against the job's limits (its policy's, else Options'), which fail or pause the job.
  void recordFailure(Job& job, Worker& worker, uint64_t unit, const std::string& error)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // The longest a lease of `job` granted at `now` may be held: Options::maxLeaseSeconds, or the
  // job's unit time limit if shorter.
  Clock::time_point longestLeaseEnd(const Job& job, Clock::time_point now) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  Admission admit(const UnitResult& result) ABSL_LOCKS_EXCLUDED(mutex_);
  void record(const UnitResult& result, const Admission& a) ABSL_LOCKS_EXCLUDED(mutex_);
  bool count(const UnitResult& result, const Admission& a, AuditBook::Sums kept) ABSL_LOCKS_EXCLUDED(mutex_);
  void sumAndPublish(const UnitResult& result, UnitResult* owned, const Admission& a) ABSL_LOCKS_EXCLUDED(mutex_);
  void startLifecycle();  // the constructor's last step: retention at start-up, then its thread
  void stopLifecycle();   // the destructor's first
  void lifecycleLoop();
  // "holds 3.1 GB of its 16.0 GB: job-3 2.0 GB, ..., --memory-budget": for refusals.
  std::string memoryBudgetText() const;
  // One image's share of the budget (imageMemory), for `what`, waiting up to imageWaitSeconds for
  // room: FarmError kResourceExhausted naming what holds the budget when there is none.
  MemoryBudget::Reservation reserveImage(const RenderSettings& settings, const std::string& what) const;
  // The image of an archived job, and of one with a film (both require a JobPin or archiving).
  JobImage archivedImage(const Job& job) const;
  // The job's image from its film (an animation's frame: from the film or the frame store).
  JobImage developedImage(const Job& job, std::optional<int64_t> frame = std::nullopt) const;
  // What an archived job keeps of its film's progress (a JSON object, stored with the job).
  static std::string summaryOf(const Job& job);
  static void restoreSummary(Job& job, const std::string& summary);
  std::unique_ptr<class JobArchive> archive_;
  // Every frame-sized thing held, reserved before it is allocated (Options::memoryBudgetBytes).
  // Its own lock; reservations live in Jobs, JobImages and assetMemory_.
  std::shared_ptr<MemoryBudget> memory_;
  // Without a state dir, each asset's bytes in memory, by SHA-256.
  std::map<std::string, MemoryBudget::Reservation> assetMemory_ ABSL_GUARDED_BY(mutex_);
  std::thread lifecycleThread_;
  std::condition_variable lifecycleWake_;  // with mutex_: a job ended, or the coordinator stops
  bool lifecycleStopping_ ABSL_GUARDED_BY(mutex_) = false;
  bool lifecycleDue_ ABSL_GUARDED_BY(mutex_) = false;          // a job ended since the last pass
  std::set<std::string> deletedJobs_ ABSL_GUARDED_BY(mutex_);  // ids deleted by this run

  // ---- durable state (persistence.cpp) ----
  // Stores the frames an animation's film completed (outside mutex_), then drops their unit files.
  void storeCompletedFrames(Job& job);
  ImageMetadata metadataOf(const Job& job) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void restore();
  void setWorkerEpoch() ABSL_LOCKS_EXCLUDED(mutex_);  // worker ids name this run (epoch_)
  // The jobs of the state dir, back in the table; those with tiles into `tiled` (their completed
  // frames are stored next, outside the lock).
  void restoreJobs(std::vector<Job*>& tiled) ABSL_LOCKS_EXCLUDED(mutex_);
  std::unique_ptr<Job> jobFromRow(const StateStore::StoredJob& stored, Scene* scene);
  uint64_t restoreFilm(Job& job, const Scene& scene, const StateStore::StoredJob& stored, Clock::time_point now,
                       double nowUnix) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A tiled job's film from its stored frames and its ledger; returns the highest unit counted.
  std::optional<uint64_t> restoreTiled(Job& job);
  std::optional<uint64_t> replayStoredUnits(Job& job, const std::function<bool(uint64_t)>& fileExpected);
  void reportRepair(Job& job, const std::string& repair);
  void persistState(const Job& job) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void checkpointLoop();

  // ---- scheduling (scheduling.cpp) ----
  // Whether `job`, which has units to lease, may be leased to `worker` now by its policy and
  // state: not paused, its dependencies held, the worker has its tags, its cap is not reached and
  // no idle worker it prefers is waiting.
  bool policyAllows(const Job& job, const Worker& worker, Clock::time_point now) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // The deadline-aware share: a job with a target error and a deadline is *urgent* when, at its
  // measured speed, reaching its target needs more of the farm's remaining time before the
  // deadline than its fair share (1 / the owners with work at its priority). Urgent jobs come
  // before the others of their priority, earliest deadline first. Updates the job's outlook (and
  // says once, in an event, when the target is out of reach even with the whole farm).
  bool urgent(Job& job, size_t ownersSharing, Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Among jobs that may be leased to a worker: whether `a` is served before `b` (priority, then
  // urgency (earliest deadline first), then fair share or submission order, Options::sharing).
  // `urgentA`, `urgentB`: urgent() of each.
  bool leasedBefore(const Job& a, bool urgentA, const Job& b, bool urgentB) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // A lease of `unit` of `job` was granted: its owner and the job are charged (fair_share.h).
  void chargeShare(const Job& job, uint64_t unit) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Releases the jobs whose dependencies now hold, and fails (or marks waiting) those whose
  // dependencies can no longer hold.
  void updateDependencies() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // What `job`'s dependencies wait for (JobInfo::waitingFor), and in `*broken` the first that can
  // no longer hold ("job-7 was cancelled"), if any.
  std::vector<std::string> dependencyWaits(const Job& job, std::string* broken) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // pauseJob (true) and resumeJob (false).
  JobInfo setPaused(const std::string& jobId, bool paused) ABSL_LOCKS_EXCLUDED(mutex_);
  // Refuses (kNotFound) a policy waiting for a job that does not exist.
  void checkDependenciesExist(const JobPolicy& policy) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // "no connected worker has the tags it requires (bigmem; connected: w1 [studio-a], ...)", or
  // "" when one has.
  std::string tagsStall(const Job& job, Clock::time_point now) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  FairShare share_ ABSL_GUARDED_BY(mutex_);
  // The per-owner quotas at submission (Options::maxAssetBytesPerOwner, maxSamplesPerOwner).
  void checkOwnerQuotas(const std::string& owner, const JobSpec& spec, uint64_t pixelSamples) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Since when (steady seconds) each stored asset no job refers to has been so (collectAssets).
  std::map<std::string, double> assetUnreferencedSince_ ABSL_GUARDED_BY(mutex_);
  // The job (prefetched, not ended, its tags held) whose assets `worker` has not been asked to
  // fetch yet; null if none.
  const Job* prefetchFor(const Worker& worker) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Publishes a notification about the job (event_feed.h).
  void notify(const Job& job, const char* type, std::string text) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  EventFeed events_;  // its own lock

  // ---- workers (workers.cpp) ----
  Worker& findWorker(const std::string& workerId) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  Worker* liveWorker(const std::string& workerId)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);  // null if unknown, lost or left
  WorkerState stateOf(const Worker& worker, bool holdsLease, Clock::time_point now, double* secondsInState) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  std::string stalledReason(const Job& job, Clock::time_point now) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  double staleAfterSeconds() const;
  void forgetSilentWorkers(Clock::time_point now) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  Options options_;
  std::unique_ptr<class StateStore> store_;
  std::unique_ptr<class FrameStore> frames_;  // animations' completed frames (frame_store.h)
  uint64_t epoch_ = 0;                        // distinguishes ids issued by this run from those of earlier runs
  std::thread checkpointer_;
  std::condition_variable checkpointWake_;
  bool stopping_ ABSL_GUARDED_BY(mutex_) = false;
  mutable Mutex mutex_;
  mutable std::condition_variable changed_;  // any job changed, or work became available
  AssetStore assets_;                        // its own lock
  std::map<std::string, std::unique_ptr<Job>> jobs_ ABSL_GUARDED_BY(mutex_);
  WorkerRegistry workers_ ABSL_GUARDED_BY(mutex_);
  LeaseTable leases_ ABSL_GUARDED_BY(mutex_);
  uint64_t nextJob_ ABSL_GUARDED_BY(mutex_) = 1;
  uint64_t nextSequence_ ABSL_GUARDED_BY(mutex_) = 1, nextAttachment_ ABSL_GUARDED_BY(mutex_) = 1;
  // orders accepted units for the audit (JobAudit::Provenance::seq)
  uint64_t nextAcceptance_ ABSL_GUARDED_BY(mutex_) = 1;
  std::mt19937_64 auditRandom_ ABSL_GUARDED_BY(mutex_);  // which units are audited; seeded by the operating system
  // Held while a job's checkpoint is taken and written, and by a rewind that rewrites it.
  std::mutex checkpointMutex_;

  // The state dir refused a write (a full disk, a quota, an I/O error: StorageError): no unit is
  // leased until a probe write succeeds (checkpointLoop, every kStorageProbeSeconds), and every
  // running job says why in its stalled reason; workers wait in LeaseWork instead of rendering
  // units that could not be kept.
  struct StorageStall {
    std::string reason;  // the file (relative to the state dir) and errno's text
    Clock::time_point since;
  };
  static constexpr double kStorageProbeSeconds = 2.0;
  std::optional<StorageStall> storageStall_ ABSL_GUARDED_BY(mutex_);
  void storageFailed(const class StorageError& e) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void probeStorage() ABSL_LOCKS_EXCLUDED(mutex_);

  // Counted for metricsSnapshot() since this process started (the assets' by assets_).
  struct Counters {
    std::atomic<uint64_t> unitsLeased{0}, unitsDone{0}, unitsExpired{0}, samples{0}, unitBytes{0}, unitWireBytes{0};
    std::atomic<uint64_t> workersLost{0}, stateWriteFailures{0};
    std::atomic<uint64_t> auditsPassed{0}, auditsFailed{0}, auditsExplained{0}, unitsRerendered{0};
    std::atomic<uint64_t> backupLeases{0};  // units also leased to a faster worker (tryBackupLease)
  };
  Counters counters_;
};

}  // namespace lensfarm
