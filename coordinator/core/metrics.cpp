#include "coordinator/core/metrics.h"

#include <charconv>
#include <map>

#include "common/util/version.h"

namespace lensfarm {

namespace {

// Appends metric families: HELP and TYPE once, then samples with optional labels.
class Exposition {
 public:
  void family(const char* name, const char* type, const char* help) {
    name_ = name;
    out_ += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
  }
  void sample(double value, const std::string& labels = "") {
    char text[64];
    const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
    out_ += name_ + (labels.empty() ? "" : "{" + labels + "}") + " " + std::string(text, end) + "\n";
  }
  void sample(uint64_t value, const std::string& labels = "") {
    out_ += name_ + (labels.empty() ? "" : "{" + labels + "}") + " " + std::to_string(value) + "\n";
  }
  std::string text() && { return std::move(out_); }

 private:
  std::string out_, name_;
};

// Appends lensfarm_jobs (by state); returns the running jobs' samples per second, summed.
double jobMetrics(Exposition& e, const MetricsSnapshot& s) {
  std::map<JobState, uint64_t> byState;
  for (JobState state :
       {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kCancelled, JobState::kFailed})
    byState[state] = 0;
  double samplesPerSecond = 0.0;
  for (const JobInfo& job : s.jobs) {
    ++byState[job.state];
    if (job.state == JobState::kRunning && job.elapsedSeconds > 0)
      samplesPerSecond += double(job.stats.paths) / job.elapsedSeconds;
  }
  e.family("lensfarm_jobs", "gauge", "Jobs the coordinator holds, by state.");
  for (const auto& [state, count] : byState) e.sample(count, std::string("state=\"") + jobStateName(state) + "\"");
  return samplesPerSecond;
}

// Appends the bytes received and the asset uploads and sends.
void transferMetrics(Exposition& e, const MetricsSnapshot& s) {
  e.family("lensfarm_received_bytes_total", "counter",
           "Payload bytes received: kind=\"unit\" result buffers from workers, kind=\"asset\" assets from clients.");
  e.sample(s.unitBytesReceived, "kind=\"unit\"");
  e.sample(s.assetBytesReceived, "kind=\"asset\"");
  e.family("lensfarm_unit_wire_bytes_total", "counter",
           "Bytes of unit result sums received from workers as sent over gRPC: compressed when the lease asked for "
           "SUMS_ENCODING_SHUFFLE_ZSTD (the decoded doubles are lensfarm_received_bytes_total{kind=\"unit\"}).");
  e.sample(s.unitWireBytesReceived);
  e.family("lensfarm_asset_uploads_total", "counter",
           "Asset uploads from clients: outcome=\"stored\" an asset new to the coordinator, outcome=\"present\" one "
           "it held already (answered after the first message). Clients that ask FindMissingAssets first make none of "
           "the second kind.");
  e.sample(s.assetUploadsStored, "outcome=\"stored\"");
  e.sample(s.assetUploadsPresent, "outcome=\"present\"");
  e.family("lensfarm_assets_sent_total", "counter",
           "Assets sent to workers (FetchAsset). A worker fetches each asset once into its cache, so this grows by "
           "the assets of a job once per worker new to them, not per unit.");
  e.sample(s.assetsSent);
  e.family("lensfarm_asset_bytes_resident", "gauge",
           "Asset bytes held in memory now: with a state dir only those in use (a job's scene being loaded, a "
           "worker fetching one), else every uploaded asset.");
  e.sample(s.assetBytesResident);
  e.family("lensfarm_asset_bytes_stored", "gauge",
           "Asset bytes kept, in memory or on disk: what --max-asset-bytes limits and the garbage collection "
           "(--asset-grace) frees.");
  e.sample(s.assetBytesStored);
  e.family("lensfarm_assets_collected_total", "counter",
           "Assets removed because no job had referred to them for --asset-grace (uploaded and never submitted, or "
           "their last job deleted).");
  e.sample(s.assetsCollected);
  e.family("lensfarm_memory_budget_bytes", "gauge",
           "The coordinator's memory budget (--memory-budget): what jobs' films, images being served or archived, "
           "and without a state dir assets and archived images may hold together.");
  e.sample(s.memoryBudgetBytes);
  e.family("lensfarm_memory_reserved_bytes", "gauge",
           "Bytes reserved from the memory budget now. A job that does not fit is refused; a download waits for room.");
  e.sample(s.memoryReservedBytes);
}

// Appends the worker families: alive, known, by state, lost and quarantined.
void workerMetrics(Exposition& e, const MetricsSnapshot& s) {
  uint64_t alive = 0, quarantined = 0;
  std::map<WorkerState, uint64_t> workersByState;
  for (WorkerState state :
       {WorkerState::kRendering, WorkerState::kIdle, WorkerState::kStale, WorkerState::kLost, WorkerState::kLeft})
    workersByState[state] = 0;
  for (const WorkerView& w : s.workers) {
    ++workersByState[w.state];
    if (w.secondsSinceHeartbeat <= s.leaseTimeoutSeconds && w.state != WorkerState::kLost &&
        w.state != WorkerState::kLeft)
      ++alive;
    if (w.quarantined) ++quarantined;
  }
  e.family("lensfarm_workers_alive", "gauge",
           "Workers heard from (heartbeat or lease request) within the lease timeout, and not lost or left.");
  e.sample(alive);
  e.family("lensfarm_workers_known", "gauge", "Workers registered and not yet forgotten, alive or silent.");
  e.sample(uint64_t(s.workers.size()));
  e.family(
      "lensfarm_workers", "gauge",
      "Known workers by state: rendering, idle, stale (heartbeats late), lost (connection broke or silent past the "
      "lease timeout), left (stopped cleanly).");
  for (const auto& [state, count] : workersByState)
    e.sample(count, std::string("state=\"") + workerStateName(state) + "\"");
  e.family("lensfarm_workers_lost_total", "counter",
           "Workers marked lost at once because their Attach stream broke (their units were queued again).");
  e.sample(s.workersLost);
  e.family("lensfarm_state_write_failures_total", "counter",
           "Writes the state dir refused (a full disk, a quota, an I/O error); the log names the file and the error.");
  e.sample(s.stateWriteFailures);
  e.family("lensfarm_state_writes_stalled", "gauge",
           "1 while the state dir refuses writes: no unit is leased until a probe write goes through.");
  e.sample(uint64_t(s.stateWritesStalled));
  e.family("lensfarm_workers_quarantined", "gauge",
           "Known workers quarantined by the cross-worker audit: leased nothing more until the coordinator restarts.");
  e.sample(quarantined);
}

}  // namespace

std::string renderMetrics(const MetricsSnapshot& s) {
  Exposition e;
  e.family("lensfarm_build_info", "gauge", "The renderer version this coordinator runs (always 1).");
  e.sample(uint64_t(1), std::string("version=\"") + kRendererVersion + "\"");

  const double samplesPerSecond = jobMetrics(e, s);

  e.family("lensfarm_units_leased_total", "counter",
           "Units handed out to workers; a unit leased again after its lease lapsed counts again.");
  e.sample(s.unitsLeased);
  e.family("lensfarm_backup_leases_total", "counter",
           "Units also leased to an idle worker while a much slower one renders them, near a job's end; the first "
           "result counts.");
  e.sample(s.backupLeases);
  e.family("lensfarm_units_done_total", "counter", "Unit results accepted and counted (each unit once).");
  e.sample(s.unitsDone);
  e.family(
      "lensfarm_units_expired_total", "counter",
      "Leases that lapsed without a result (the worker died, hung or lost the network); the unit was queued again.");
  e.sample(s.unitsExpired);
  e.family("lensfarm_leases_active", "gauge", "Units leased to workers now.");
  e.sample(s.leasesActive);
  e.family("lensfarm_audits_total", "counter",
           "Units rendered again by another worker and compared (the cross-worker audit): result=\"passed\" the two "
           "results agreed, result=\"failed\" they did not and a third worker found the wrong one, "
           "result=\"explained\" they differed as two builds' rounding does (nobody was wrong).");
  e.sample(s.auditsPassed, "result=\"passed\"");
  e.sample(s.auditsFailed, "result=\"failed\"");
  e.sample(s.auditsExplained, "result=\"explained\"");
  e.family("lensfarm_units_rerendered_total", "counter",
           "Counted units queued again because an audit found the worker that rendered them wrong.");
  e.sample(s.unitsRerendered);

  e.family("lensfarm_samples_total", "counter", "Samples (camera paths) in the accepted unit results.");
  e.sample(s.samples);
  e.family("lensfarm_samples_per_second", "gauge",
           "Samples per second of the running jobs: each job's accumulated samples over its elapsed time, summed.");
  e.sample(samplesPerSecond);

  transferMetrics(e, s);

  workerMetrics(e, s);
  return std::move(e).text();
}

}  // namespace lensfarm
