#include "coordinator/store/state_store.h"
#include "common/util/file_contents.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "common/film/image_io.h"
#include "common/scene/scene.h"
#include "common/util/atomic_file.h"
#include "common/util/version.h"

namespace lensfarm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A prepared statement that finalizes itself; bind() by 1-based index.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("state.db: ") + sqlite3_errmsg(db));
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement& bind(int i, const std::string& v) {
    sqlite3_bind_text(stmt_, i, v.data(), int(v.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Statement& bind(int i, int64_t v) {
    sqlite3_bind_int64(stmt_, i, v);
    return *this;
  }
  Statement& bind(int i, double v) {
    sqlite3_bind_double(stmt_, i, v);
    return *this;
  }
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw std::runtime_error(std::string("state.db: ") + sqlite3_errmsg(db_));
  }
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p), size_t(sqlite3_column_bytes(stmt_, col))) : "";
  }
  int64_t integer(int col) const { return sqlite3_column_int64(stmt_, col); }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

std::string readAll(const fs::path& p) { return readWholeFileOrThrow(p, p.string()); }

// Writes the pieces one after another into `path`, atomically, without joining them in memory
// first (a checkpoint's pieces are frame-sized).
void writePiecesAtomically(const fs::path& path, std::initializer_list<std::pair<const char*, size_t>> pieces) {
  writeFileAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    for (const auto& [data, size] : pieces) out.write(data, std::streamsize(size));
    out.close();
    if (!out) throw std::runtime_error("write failed");
  });
}

json specToJson(const JobSpec& spec) {
  json out{{"scene_name", spec.sceneName},
           {"scene_json", spec.sceneJson},
           {"assets", spec.assets},
           {"overrides", overridesToJson(spec.overrides)}};
  if (spec.frames) out["frames"] = {spec.frames->first, spec.frames->last, spec.frames->step};
  return out;
}

JobSpec specFromJson(const json& j) {
  JobSpec spec;
  spec.sceneName = j.at("scene_name").get<std::string>();
  spec.sceneJson = j.at("scene_json").get<std::string>();
  spec.assets = j.at("assets").get<std::map<std::string, std::string>>();
  spec.overrides = overridesFromJson(j.at("overrides"));
  if (j.contains("frames")) {
    const json& f = j["frames"];
    spec.frames = FrameRange{f.at(0).get<int64_t>(), f.at(1).get<int64_t>(), f.at(2).get<int64_t>()};
  }
  return spec;
}

}  // namespace

StateStore::StateStore(fs::path dir) : dir_(std::move(dir)) {
  fs::create_directories(dir_ / "assets");
  fs::create_directories(dir_ / "jobs");
  // One coordinator per state dir: a second would corrupt the first's ledger.
  lockFd_ = ::open((dir_ / "lock").c_str(), O_RDWR | O_CREAT, 0600);
  if (lockFd_ < 0 || ::flock(lockFd_, LOCK_EX | LOCK_NB) != 0)
    throw std::runtime_error("another coordinator is using " + dir_.string());
  if (sqlite3_open((dir_ / "state.db").c_str(), &db_) != SQLITE_OK)
    throw std::runtime_error("cannot open " + (dir_ / "state.db").string() + ": " + sqlite3_errmsg(db_));
  exec("PRAGMA journal_mode=WAL");
  exec("PRAGMA synchronous=FULL");
  exec("CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value INTEGER)");
  exec(
      "CREATE TABLE IF NOT EXISTS jobs(id TEXT PRIMARY KEY, sequence INTEGER, priority INTEGER, spec TEXT, "
      "state TEXT, error TEXT, submitted REAL, folded_units INTEGER, stop_units INTEGER, stop_reason TEXT)");
  // Added by the job life cycle; a state dir written before it gains them empty.
  addColumnIfMissing("jobs", "owner", "TEXT");
  addColumnIfMissing("jobs", "ended", "REAL");
  addColumnIfMissing("jobs", "archived", "INTEGER");
  addColumnIfMissing("jobs", "summary", "TEXT");
  exec(
      "CREATE TABLE IF NOT EXISTS ledger(job_id TEXT, unit INTEGER, worker TEXT, paths INTEGER, rays INTEGER, "
      "light_hits INTEGER, dropped INTEGER, PRIMARY KEY(job_id, unit))");
  exec("CREATE TABLE IF NOT EXISTS stamp(key TEXT PRIMARY KEY, value TEXT)");
  {
    // Units rendered by another renderer version would mix two images in one sensor.
    Statement read(db_, "SELECT value FROM stamp WHERE key = 'renderer_version'");
    if (read.step()) {
      const std::string written = read.text(0);
      if (written != kRendererVersion)
        throw std::runtime_error(dir_.string() + " was written by " + written + ", this coordinator is " +
                                 kRendererVersion + "; finish its jobs with that version or use another state dir");
    } else {
      Statement(db_, "INSERT INTO stamp(key, value) VALUES('renderer_version', ?)")
          .bind(1, std::string(kRendererVersion))
          .step();
    }
  }
  exec("INSERT INTO meta(key, value) VALUES('boots', 1) ON CONFLICT(key) DO UPDATE SET value = value + 1");
  Statement s(db_, "SELECT value FROM meta WHERE key = 'boots'");
  if (s.step()) bootCount_ = uint64_t(s.integer(0));
}

StateStore::~StateStore() {
  sqlite3_close(db_);
  if (lockFd_ >= 0) ::close(lockFd_);  // releases the lock
}

void StateStore::exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string what = error ? error : "unknown error";
    sqlite3_free(error);
    throw std::runtime_error("state.db: " + what);
  }
}

void StateStore::addColumnIfMissing(const std::string& table, const std::string& column, const std::string& type) {
  Statement s(db_, ("SELECT count(*) FROM pragma_table_info('" + table + "') WHERE name = '" + column + "'").c_str());
  if (s.step() && s.integer(0) == 0) exec("ALTER TABLE " + table + " ADD COLUMN " + column + " " + type);
}

fs::path StateStore::jobDir(const std::string& jobId) const { return dir_ / "jobs" / jobId; }

void StateStore::putAsset(const std::string& sha256, const std::string& bytes) {
  writeBytesAtomically(dir_ / "assets" / sha256, bytes);
}

std::map<std::string, std::shared_ptr<const std::string>> StateStore::loadAssets() {
  std::map<std::string, std::shared_ptr<const std::string>> out;
  for (const auto& entry : fs::directory_iterator(dir_ / "assets"))
    if (entry.is_regular_file() && entry.path().filename().string().front() != '.')
      out[entry.path().filename().string()] = std::make_shared<const std::string>(readAll(entry.path()));
  return out;
}

void StateStore::insertJob(const StoredJob& job) {
  std::lock_guard lock(mutex_);
  fs::create_directories(jobDir(job.id));
  Statement(db_,
            "INSERT INTO jobs(id, sequence, priority, spec, state, error, submitted, folded_units, owner, "
            "ended, archived) VALUES(?, ?, ?, ?, ?, ?, ?, 0, ?, 0, 0)")
      .bind(1, job.id)
      .bind(2, int64_t(job.sequence))
      .bind(3, int64_t(job.priority))
      .bind(4, specToJson(job.spec).dump())
      .bind(5, job.state)
      .bind(6, job.error)
      .bind(7, job.submittedUnixSeconds)
      .bind(8, job.owner)
      .step();
  if (job.id.rfind("job-", 0) == 0)
    Statement(db_,
              "INSERT INTO meta(key, value) VALUES('last_job', ?) "
              "ON CONFLICT(key) DO UPDATE SET value = max(value, excluded.value)")
        .bind(1, int64_t(std::stoull(job.id.substr(4))))
        .step();
}

uint64_t StateStore::lastJobNumber() {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT value FROM meta WHERE key = 'last_job'");
  return s.step() ? uint64_t(s.integer(0)) : 0;
}

void StateStore::inTransaction(const std::function<void()>& body) {
  std::lock_guard lock(mutex_);
  exec("BEGIN IMMEDIATE");
  try {
    body();
    exec("COMMIT");
  } catch (...) {
    exec("ROLLBACK");
    throw;
  }
}

void StateStore::markArchived(const std::string& jobId, const std::string& summary) {
  inTransaction([&] {
    Statement(db_, "UPDATE jobs SET archived = 1, summary = ?, folded_units = 0 WHERE id = ?")
        .bind(1, summary)
        .bind(2, jobId)
        .step();
    Statement(db_, "DELETE FROM ledger WHERE job_id = ?").bind(1, jobId).step();
  });
  // The row says archived: a crash from here on leaves files that restore() ignores and removes.
  std::error_code ignored;
  if (!fs::exists(jobDir(jobId), ignored)) return;
  for (const auto& entry : fs::directory_iterator(jobDir(jobId))) {
    const std::string name = entry.path().filename().string();
    if (name == "sensor.bin" || name.rfind("unit-", 0) == 0 || name.rfind(".", 0) == 0)
      fs::remove(entry.path(), ignored);
  }
}

void StateStore::deleteJob(const std::string& jobId) {
  inTransaction([&] {
    Statement(db_, "DELETE FROM ledger WHERE job_id = ?").bind(1, jobId).step();
    Statement(db_, "DELETE FROM jobs WHERE id = ?").bind(1, jobId).step();
  });
  // No row names the job now: a crash before its directory is gone leaves an orphan that the
  // next start removes (removeOrphanJobDirs).
  std::error_code ignored;
  fs::remove_all(jobDir(jobId), ignored);
}

void StateStore::removeOrphanJobDirs() {
  std::set<std::string> known;
  {
    std::lock_guard lock(mutex_);
    Statement s(db_, "SELECT id FROM jobs");
    while (s.step()) known.insert(s.text(0));
  }
  std::error_code ignored;
  for (const auto& entry : fs::directory_iterator(dir_ / "jobs"))
    if (entry.is_directory() && !known.count(entry.path().filename().string())) fs::remove_all(entry.path(), ignored);
}

void StateStore::updateJobState(const std::string& jobId, const std::string& state, const std::string& error,
                                const std::optional<uint64_t>& stopUnits, const std::string& stopReason,
                                double endedUnixSeconds) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET state = ?, error = ?, stop_units = ?, stop_reason = ?, ended = ? WHERE id = ?")
      .bind(1, state)
      .bind(2, error)
      .bind(3, stopUnits ? int64_t(*stopUnits) : int64_t(-1))
      .bind(4, stopReason)
      .bind(5, endedUnixSeconds)
      .bind(6, jobId)
      .step();
}

void StateStore::updateJobPriority(const std::string& jobId, int priority) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET priority = ? WHERE id = ?").bind(1, int64_t(priority)).bind(2, jobId).step();
}

std::vector<StateStore::StoredJob> StateStore::loadJobs() {
  std::lock_guard lock(mutex_);
  std::vector<StoredJob> out;
  Statement s(db_,
              "SELECT id, sequence, priority, spec, state, error, submitted, folded_units, "
              "coalesce(stop_units, -1), coalesce(stop_reason, ''), coalesce(owner, ''), coalesce(ended, 0), "
              "coalesce(archived, 0), coalesce(summary, '') FROM jobs ORDER BY sequence");
  while (s.step()) {
    StoredJob j;
    j.id = s.text(0);
    j.sequence = uint64_t(s.integer(1));
    j.priority = int(s.integer(2));
    j.spec = specFromJson(json::parse(s.text(3)));
    j.state = s.text(4);
    j.error = s.text(5);
    j.submittedUnixSeconds = s.real(6);
    j.foldedUnits = uint64_t(s.integer(7));
    if (s.integer(8) >= 0) j.stopUnits = uint64_t(s.integer(8));
    j.stopReason = s.text(9);
    j.owner = s.text(10);
    j.endedUnixSeconds = s.real(11);
    j.archived = s.integer(12) != 0;
    j.summary = s.text(13);
    out.push_back(std::move(j));
  }
  return out;
}

void StateStore::recordUnit(const std::string& jobId, const LedgerEntry& e, const std::vector<double>& sums) {
  const fs::path file = jobDir(jobId) / ("unit-" + std::to_string(e.unit) + ".bin");
  writePiecesAtomically(file, {{reinterpret_cast<const char*>(sums.data()), sums.size() * sizeof(double)}});
  std::lock_guard lock(mutex_);
  Statement(db_,
            "INSERT OR IGNORE INTO ledger(job_id, unit, worker, paths, rays, light_hits, dropped) "
            "VALUES(?, ?, ?, ?, ?, ?, ?)")
      .bind(1, jobId)
      .bind(2, int64_t(e.unit))
      .bind(3, e.worker)
      .bind(4, int64_t(e.stats.paths))
      .bind(5, int64_t(e.stats.rays))
      .bind(6, int64_t(e.stats.lightHits))
      .bind(7, int64_t(e.stats.dropped))
      .step();
}

void StateStore::forgetUnits(const std::string& jobId, uint64_t fromUnit, const std::set<uint64_t>& kept,
                             uint64_t toUnit) {
  std::lock_guard lock(mutex_);
  std::vector<uint64_t> units;
  {
    Statement s(db_, "SELECT unit FROM ledger WHERE job_id = ? AND unit >= ? AND unit < ?");
    s.bind(1, jobId).bind(2, int64_t(fromUnit)).bind(3, int64_t(toUnit));
    while (s.step())
      if (!kept.count(uint64_t(s.integer(0)))) units.push_back(uint64_t(s.integer(0)));
  }
  // The rows first: a unit file without a row is never read.
  for (uint64_t unit : units)
    Statement(db_, "DELETE FROM ledger WHERE job_id = ? AND unit = ?").bind(1, jobId).bind(2, int64_t(unit)).step();
  std::error_code ignored;
  for (uint64_t unit : units) fs::remove(jobDir(jobId) / ("unit-" + std::to_string(unit) + ".bin"), ignored);
}

void StateStore::dropUnitFiles(const std::string& jobId, uint64_t fromUnit, uint64_t toUnit) {
  std::error_code ignored;
  for (uint64_t unit = fromUnit; unit < toUnit; ++unit)
    fs::remove(jobDir(jobId) / ("unit-" + std::to_string(unit) + ".bin"), ignored);
}

std::vector<StateStore::LedgerEntry> StateStore::ledger(const std::string& jobId) {
  std::lock_guard lock(mutex_);
  std::vector<LedgerEntry> out;
  Statement s(db_, "SELECT unit, worker, paths, rays, light_hits, dropped FROM ledger WHERE job_id = ? ORDER BY unit");
  s.bind(1, jobId);
  while (s.step()) {
    LedgerEntry e;
    e.unit = uint64_t(s.integer(0));
    e.worker = s.text(1);
    e.stats.paths = uint64_t(s.integer(2));
    e.stats.rays = uint64_t(s.integer(3));
    e.stats.lightHits = uint64_t(s.integer(4));
    e.stats.dropped = uint64_t(s.integer(5));
    out.push_back(e);
  }
  return out;
}

std::vector<double> StateStore::loadUnitSums(const std::string& jobId, uint64_t unit, size_t count) {
  const std::string bytes = readAll(jobDir(jobId) / ("unit-" + std::to_string(unit) + ".bin"));
  if (bytes.size() != count * sizeof(double))
    throw std::runtime_error("unit " + std::to_string(unit) + " of " + jobId + " has the wrong size on disk");
  std::vector<double> sums(count);
  std::memcpy(sums.data(), bytes.data(), bytes.size());
  return sums;
}

void StateStore::writeCheckpoint(const std::string& jobId, const std::string& sensorBytes,
                                 const std::string& trackerBytes, uint64_t foldedUnits) {
  // The count of folded units travels inside the file with the sensor and the convergence
  // tracker, so the three can never disagree, whatever moment a crash picks.
  const uint64_t sensorSize = sensorBytes.size();
  writePiecesAtomically(jobDir(jobId) / "sensor.bin",
                        {{reinterpret_cast<const char*>(&foldedUnits), sizeof foldedUnits},
                         {reinterpret_cast<const char*>(&sensorSize), sizeof sensorSize},
                         {sensorBytes.data(), sensorBytes.size()},
                         {trackerBytes.data(), trackerBytes.size()}});
  {
    std::lock_guard lock(mutex_);
    Statement(db_, "UPDATE jobs SET folded_units = ? WHERE id = ?").bind(1, int64_t(foldedUnits)).bind(2, jobId).step();
  }
  // The sensor now holds these units: their files are no longer needed.
  for (const auto& entry : fs::directory_iterator(jobDir(jobId))) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("unit-", 0) != 0) continue;
    const uint64_t unit = std::stoull(name.substr(5));
    if (unit < foldedUnits) fs::remove(entry.path());
  }
}

std::optional<StateStore::Checkpoint> StateStore::loadCheckpoint(const std::string& jobId) {
  const fs::path file = jobDir(jobId) / "sensor.bin";
  if (!fs::exists(file)) return std::nullopt;
  std::string bytes = readAll(file);
  Checkpoint c;
  uint64_t sensorSize = 0;
  if (bytes.size() >= 2 * sizeof(uint64_t))
    std::memcpy(&sensorSize, bytes.data() + sizeof(uint64_t), sizeof sensorSize);
  if (bytes.size() < 2 * sizeof(uint64_t) || sensorSize > bytes.size() - 2 * sizeof(uint64_t))
    throw std::runtime_error(file.string() + " is truncated");
  std::memcpy(&c.foldedUnits, bytes.data(), sizeof(uint64_t));
  // Cut the file in place rather than copy the sensor out of it (it is most of a checkpoint).
  c.trackerBytes = bytes.substr(2 * sizeof(uint64_t) + sensorSize);
  bytes.resize(2 * sizeof(uint64_t) + sensorSize);
  bytes.erase(0, 2 * sizeof(uint64_t));
  c.sensorBytes = std::move(bytes);
  return c;
}

}  // namespace lensfarm
