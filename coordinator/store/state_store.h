#pragma once
// The coordinator's durable state under --state-dir: SQLite for the job table and the unit
// ledger, files for assets, accumulated sensors and the units not yet folded into them.
//
//   state.db                  jobs, ledger (one row per accepted unit), meta (counters)
//   assets/<sha256>           uploaded assets
//   jobs/<id>/sensor.bin      folded (uint64), sensor size (uint64), the job's sensor with units
//                             [0, folded) added, and its convergence tracker (film/convergence.h)
//   lock                      flock'ed by the one coordinator using the directory
//   jobs/<id>/unit-<k>.bin    an accepted unit's sums, until a checkpoint folds it in (a tiled
//                             job's: until its frame is stored)
//   jobs/<id>/frame-<i>.exr   a tiled job's completed frame i (frame_store.h)
//   jobs/<id>/final.exr       an archived job's final image (job_archive.h); its sensor.bin,
//                             unit files and ledger rows are then gone
//
// Every file is written atomically (write, fsync, rename) and SQLite runs with synchronous=FULL,
// so a unit acknowledged to a worker survives a SIGKILL: its file and ledger row are durable
// before the acknowledgement is sent.
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

#include "common/farm/farm_types.h"

struct sqlite3;

namespace lensfarm {

class StateStore {
 public:
  // Opens (or creates) the state in `dir`; throws std::runtime_error naming the problem.
  explicit StateStore(std::filesystem::path dir);
  ~StateStore();
  StateStore(const StateStore&) = delete;
  StateStore& operator=(const StateStore&) = delete;

  // Counts coordinator starts on this state, so ids issued after a restart never repeat.
  uint64_t bootCount() const { return bootCount_; }

  void putAsset(const std::string& sha256, const std::string& bytes);
  std::map<std::string, std::shared_ptr<const std::string>> loadAssets();

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
    std::string summary;  // an archived job's progress (Coordinator::summaryOf)
  };
  void insertJob(const StoredJob& job);
  void updateJobState(const std::string& jobId, const std::string& state, const std::string& error,
                      const std::optional<uint64_t>& stopUnits = std::nullopt, const std::string& stopReason = "",
                      double endedUnixSeconds = 0.0);
  void updateJobPriority(const std::string& jobId, int priority);
  std::vector<StoredJob> loadJobs();  // in submission order
  // The highest job number ever inserted ("job-<n>"), so ids of deleted jobs are never reissued.
  uint64_t lastJobNumber();

  // ---- the job life cycle (docs/farm.md "Job life cycle") ----
  // Archived: the job row is marked (with `summary`) and its ledger rows go, in one transaction;
  // then its sensor.bin and unit files (final.exr stays).
  void markArchived(const std::string& jobId, const std::string& summary);
  // Deleted: the job row and ledger rows in one transaction, then the job's directory.
  void deleteJob(const std::string& jobId);
  // Removes job directories with no job row (a deletion cut short by a crash).
  void removeOrphanJobDirs();

  struct LedgerEntry {
    uint64_t unit = 0;
    std::string worker;
    PathStats stats;
  };
  // Makes an accepted unit durable: its sums file, then its ledger row.
  void recordUnit(const std::string& jobId, const LedgerEntry& entry, const std::vector<double>& sums);
  std::vector<LedgerEntry> ledger(const std::string& jobId);
  std::vector<double> loadUnitSums(const std::string& jobId, uint64_t unit, size_t count);
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
  std::optional<Checkpoint> loadCheckpoint(const std::string& jobId);

 private:
  void exec(const std::string& sql);
  void addColumnIfMissing(const std::string& table, const std::string& column, const std::string& type);
  void inTransaction(const std::function<void()>& body);  // takes mutex_; rolls back if body throws
  std::filesystem::path jobDir(const std::string& jobId) const;

  std::filesystem::path dir_;
  sqlite3* db_ = nullptr;
  std::mutex mutex_;
  uint64_t bootCount_ = 0;
  int lockFd_ = -1;
};

}  // namespace lensfarm
