#pragma once
// The coordinator's durable state under --state-dir: SQLite for the job table and the unit
// ledger, files for assets, accumulated sensors and the units not yet folded into them.
//
//   state.db                  jobs, ledger (one row per accepted unit), meta (counters)
//   assets/<sha256>           uploaded assets
//   jobs/<id>/job.json        the job as submitted (its row's first state): a checked file
//   jobs/<id>/sensor.bin      folded (uint64), sensor size (uint64), the job's sensor with units
//                             [0, folded) added, and its convergence tracker (film/convergence.h):
//                             a checked file
//   lock                      flock'ed by the one coordinator using the directory
//   jobs/<id>/unit-<k>.bin    an accepted unit's ledger entry and sums, until a checkpoint folds
//                             it in (a tiled job's: until its frame is stored): a checked file
//   jobs/<id>/frame-<i>.exr   a tiled job's completed frame i (frame_store.h)
//   jobs/<id>/final.exr       an archived job's final image (job_archive.h); its sensor.bin,
//                             unit files and ledger rows are then gone
//   jobs/.deleting-<id>       a job being deleted (renamed first, so a crash cannot leave it
//                             looking like a job the database lost)
//   lost+found/               what was found on disk that nothing explains, kept aside, and
//                             damaged files, never deleted
//
// Every file is written atomically (write, fsync, rename) and SQLite runs in WAL mode with
// synchronous=FULL (each commit's WAL frames fsync'ed before it returns), so a unit acknowledged
// to a worker survives a SIGKILL: its file and ledger row are durable before the acknowledgement
// is sent. The files are the truth of what was rendered and the database their index: a checked
// file (checked_file.h) says when it is damaged, and at start the two are reconciled
// (reconcileUnits, recoverJobs): a unit whose file is damaged is rendered again, a unit file or
// job directory the database lost (a truncated WAL, a damaged or emptied state.db, which is kept
// aside and started anew) is taken back from the files, each with a line saying so.
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/farm/farm_event.h"
#include "common/farm/farm_types.h"

struct sqlite3;

namespace lensfarm {

class StateStore {
 public:
  // Opens (or creates) the state in `dir`; throws std::runtime_error naming the problem. A
  // state.db SQLite finds damaged is moved aside (state.db.damaged-<time>) and started anew:
  // recoverJobs() then takes the jobs back from their files.
  explicit StateStore(std::filesystem::path dir);

  // What opening found and repaired (a damaged database moved aside), for the log.
  const std::vector<std::string>& openingRepairs() const { return openingRepairs_; }
  ~StateStore();
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  // Counts coordinator starts on this state, so ids issued after a restart never repeat.
  uint64_t bootCount() const { return bootCount_; }

  void putAsset(const std::string& sha256, const std::string& bytes);
  // The stored assets and their sizes (their bytes are not read).
  std::map<std::string, uint64_t> listAssets();
  // An asset's bytes, or nullopt if its file cannot be read.
  std::optional<std::string> loadAsset(const std::string& sha256);
  // A damaged asset file goes to lost+found/, with an error line saying why.
  void setAssetAside(const std::string& sha256, const std::string& why);
  // Removes a collected asset's file (AssetStore::remove); a file already gone is no error.
  void removeAsset(const std::string& sha256);

  // The farm's events (coordinator/core/event_feed.h), so numbering and webhooks go on after a
  // restart: appendEvent keeps the newest `keep`; loadEvents gives them oldest first.
  void appendEvent(const FarmEvent& event, size_t keep);
  std::vector<FarmEvent> loadEvents();
  // The last event a webhook URL has had (delivered or given up), or nullopt for a URL new here.
  std::optional<uint64_t> webhookCursor(const std::string& url);
  void setWebhookCursor(const std::string& url, uint64_t sequence);

  struct StoredJob {
    std::string id;
    uint64_t sequence = 0;
    int priority = 0;
    JobSpec spec;
    std::string state;  // jobStateName()
    std::string error;
    double submittedUnixSeconds = 0.0;
    uint64_t foldedUnits = 0;           // units in sensor.bin
    std::optional<uint64_t> stopUnits;  // a job stopped early keeps units [0, stopUnits)
    std::string stopReason;
    std::string owner;
    double endedUnixSeconds = 0.0;  // 0: not ended (or ended before this column existed)
    bool archived = false;
    std::string summary;   // an archived job's progress (Coordinator::summaryOf)
    std::string kernel{};  // its pinned traversal kernel (util/trace_kernel.h); empty: not yet
    // Scheduling (docs/farm.md "Scheduling"): its policy (farm/job_policy.h, policyToJson; empty:
    // the default), paused, approved, and released (its dependencies held once).
    std::string policy{};
    bool paused = false, approved = false, released = true;
  };
  void insertJob(const StoredJob& job);
  void updateJobState(const std::string& jobId, const std::string& state, const std::string& error,
                      const std::optional<uint64_t>& stopUnits = std::nullopt, const std::string& stopReason = "",
                      double endedUnixSeconds = 0.0);
  void updateJobPriority(const std::string& jobId, int priority);
  void updateJobPolicy(const std::string& jobId, const std::string& policy);  // policyToJson text
  void updateJobSchedule(const std::string& jobId, bool paused, bool approved, bool released);
  // The job's pinned traversal kernel; `inManifest`: written into its job.json as well (once, when
  // it is pinned), so a job taken back from its files keeps it.
  void updateJobKernel(const std::string& jobId, const std::string& kernel, bool inManifest = false);
  std::vector<StoredJob> loadJobs();  // in submission order
  // The highest job number ever inserted ("job-<n>"), so ids of deleted jobs are never reissued.
  uint64_t lastJobNumber();

  // ---- the job life cycle (docs/farm.md "Job life cycle") ----
  // Archived: the job row is marked (with `summary`) and its ledger rows go, in one transaction;
  // then its sensor.bin and unit files (final.exr stays).
  void markArchived(const std::string& jobId, const std::string& summary);
  // Deleted: the job row and ledger rows in one transaction, then the job's directory.
  void deleteJob(const std::string& jobId);
  // Reconciles the job directories with the job rows: a deletion cut short by a crash is
  // finished; a directory with a valid job.json but no row (the database lost it) gets its row
  // back, as submitted (state queued); anything else is moved to lost+found/. Returns what it did,
  // one line each, naming the files.
  std::vector<std::string> recoverJobs();

  struct LedgerEntry {
    uint64_t unit = 0;
    std::string worker;
    PathStats stats;
    // The build and kernel it was rendered with ("gcc 12.2.0 Release, ... (avx512)"): the EXR's
    // provenance. Empty for a row written before the column, or rebuilt from its unit file.
    std::string build{};
  };
  // Makes an accepted unit durable: its checked file (entry and sums), then its ledger row. Throws
  // StorageError (checked_file.h) when the file cannot be written: then there is no row either.
  void recordUnit(const std::string& jobId, const LedgerEntry& entry, const std::vector<double>& sums);
  std::vector<LedgerEntry> ledger(const std::string& jobId);

  struct StoredUnit {
    LedgerEntry entry;
    std::optional<std::vector<double>> sums;  // present when its file was expected
  };
  struct Reconciled {
    std::vector<StoredUnit> units;     // in unit order
    std::vector<std::string> repairs;  // one line per kind of repair, naming the units
  };
  // The job's accepted units as its ledger and its files agree. `fileExpected(unit)`: whether the
  // unit's sums must be on disk (not folded into the checkpoint, not in a stored frame);
  // `sumsOf(unit)`: how many doubles its file holds. A row whose needed file is missing or damaged
  // is dropped (the unit is rendered again; a damaged file goes to lost+found/); a valid unit
  // file without a row is taken back (the database lost the commit); a row that differs from its
  // file is corrected from the file.
  Reconciled reconcileUnits(const std::string& jobId, const std::function<bool(uint64_t)>& fileExpected,
                            const std::function<size_t(uint64_t)>& sumsOf);
  // The audit undid units (docs/farm.md "Audit"): every ledger row and unit file of the job in
  // [fromUnit, toUnit), except those of `kept`, is removed.
  void forgetUnits(const std::string& jobId, uint64_t fromUnit, const std::set<uint64_t>& kept,
                   uint64_t toUnit = std::numeric_limits<int64_t>::max());

  // A tiled job's frame is stored (frame_store.h): the unit files of [fromUnit, toUnit) are
  // removed; their ledger rows stay (they say the units are counted, and their counters).
  void dropUnitFiles(const std::string& jobId, uint64_t fromUnit, uint64_t toUnit);

  // Saves the sensor and tracker holding units [0, foldedUnits), then drops their unit files.
  void writeCheckpoint(const std::string& jobId, const std::string& sensorBytes, const std::string& trackerBytes,
                       uint64_t foldedUnits);
  struct Checkpoint {
    uint64_t foldedUnits = 0;
    std::string sensorBytes;
    std::string trackerBytes;
  };
  // The job's checkpoint, or nullopt if it has none; a damaged one is moved to lost+found/,
  // `damage` says why, and nullopt is returned (its units are then rendered again).
  std::optional<Checkpoint> loadCheckpoint(const std::string& jobId, std::string* damage = nullptr);
  // Moves a damaged state file into lost+found/ (kept, never deleted); returns where it went.
  std::filesystem::path setAside(const std::filesystem::path& file);

 private:
  void open();  // opens state.db and its schema; throws on a damaged database
  void writeManifest(const StoredJob& job);
  void exec(const std::string& sql);
  void addColumnIfMissing(const std::string& table, const std::string& column, const std::string& type);
  void inTransaction(const std::function<void()>& body);  // takes mutex_; rolls back if body throws
  std::filesystem::path jobDir(const std::string& jobId) const;

  std::filesystem::path dir_;
  sqlite3* db_ = nullptr;
  std::mutex mutex_;
  uint64_t bootCount_ = 0;
  int lockFd_ = -1;
  std::vector<std::string> openingRepairs_;
};

}  // namespace lensfarm
