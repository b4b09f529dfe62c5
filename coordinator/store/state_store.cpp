#include "coordinator/store/state_store.h"
#include "common/util/file_contents.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "common/film/image_io.h"
#include "common/scene/scene.h"
#include "common/util/atomic_file.h"
#include "common/util/version.h"
#include "coordinator/store/checked_file.h"

namespace lensfarm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// SQLite says the database file is damaged (not merely busy or misused).
class DamagedDatabase : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void throwSqlite(sqlite3* db, const std::string& what) {
  const int code = sqlite3_errcode(db);
  if (code == SQLITE_CORRUPT || code == SQLITE_NOTADB) throw DamagedDatabase("state.db: " + what);
  // A full disk or an I/O error is the disk's, as for the files (a stall, not a bug).
  const char* file = sqlite3_db_filename(db, "main");
  if (code == SQLITE_FULL) throw StorageError(file ? file : "state.db", ENOSPC);
  if (code == SQLITE_IOERR) throw StorageError(file ? file : "state.db", EIO);
  throw std::runtime_error("state.db: " + what);
}

// A prepared statement that finalizes itself; bind() by 1-based index.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) throwSqlite(db, sqlite3_errmsg(db));
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
    throwSqlite(db_, sqlite3_errmsg(db_));
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

// "unit 3", "units 3, 5-9": a sorted list of units for a line of the log.
std::string unitList(const std::vector<uint64_t>& units) {
  std::string out;
  for (size_t i = 0; i < units.size();) {
    size_t j = i;
    while (j + 1 < units.size() && units[j + 1] == units[j] + 1) ++j;
    out += (out.empty() ? "" : ", ") + std::to_string(units[i]) + (j > i ? "-" + std::to_string(units[j]) : "");
    i = j + 1;
  }
  return (units.size() == 1 ? "unit " : "units ") + out;
}

// A unit file's payload: "LFUNIT01", the unit, its ledger counters, its worker, its sums.
constexpr std::string_view kUnitMagic = "LFUNIT01";

void appendU64(std::string& out, uint64_t v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }

std::string unitHeader(const StateStore::LedgerEntry& e, size_t sums) {
  std::string header(kUnitMagic);
  for (uint64_t v :
       {e.unit, e.stats.paths, e.stats.rays, e.stats.lightHits, e.stats.dropped, uint64_t(e.worker.size())})
    appendU64(header, v);
  header += e.worker;
  appendU64(header, sums);
  return header;
}

// The entry and sums of a unit file's payload, or nullopt if it is not one for `unit` with `count`
// sums.
std::optional<StateStore::StoredUnit> parseUnit(const std::string& payload, uint64_t unit, size_t count) {
  size_t at = kUnitMagic.size();
  const auto u64 = [&](uint64_t& v) {
    if (at + sizeof v > payload.size()) return false;
    std::memcpy(&v, payload.data() + at, sizeof v);
    at += sizeof v;
    return true;
  };
  StateStore::StoredUnit out;
  uint64_t workerBytes = 0, sums = 0;
  StateStore::LedgerEntry& e = out.entry;
  if (payload.compare(0, kUnitMagic.size(), kUnitMagic) != 0 || !u64(e.unit) || !u64(e.stats.paths) ||
      !u64(e.stats.rays) || !u64(e.stats.lightHits) || !u64(e.stats.dropped) || !u64(workerBytes) ||
      workerBytes > payload.size() - at)
    return std::nullopt;
  e.worker = payload.substr(at, workerBytes);
  at += workerBytes;
  if (!u64(sums) || e.unit != unit || sums != count || payload.size() - at != count * sizeof(double))
    return std::nullopt;
  out.sums.emplace(count);
  std::memcpy(out.sums->data(), payload.data() + at, count * sizeof(double));
  return out;
}

bool sameEntry(const StateStore::LedgerEntry& a, const StateStore::LedgerEntry& b) {
  return a.unit == b.unit && a.worker == b.worker && a.stats.paths == b.stats.paths && a.stats.rays == b.stats.rays &&
         a.stats.lightHits == b.stats.lightHits && a.stats.dropped == b.stats.dropped;
}

json manifestOf(const StateStore::StoredJob& job) {
  return json{{"id", job.id},
              {"sequence", job.sequence},
              {"priority", job.priority},
              {"spec", specToJson(job.spec)},
              {"owner", job.owner},
              {"policy", job.policy},
              {"submitted", job.submittedUnixSeconds}};
}

}  // namespace

StateStore::StateStore(fs::path dir) : dir_(std::move(dir)) {
  fs::create_directories(dir_ / "assets");
  fs::create_directories(dir_ / "jobs");
  // One coordinator per state dir: a second would corrupt the first's ledger.
  lockFd_ = ::open((dir_ / "lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (lockFd_ < 0 || ::flock(lockFd_, LOCK_EX | LOCK_NB) != 0)
    throw std::runtime_error("another coordinator is using " + dir_.string());
  removeStaleTemporaries(dir_, true);  // writes a crash cut short (ours only: we hold the lock)
  try {
    open();
  } catch (const DamagedDatabase& e) {
    // Kept aside, never deleted: the jobs come back from their files (recoverJobs).
    sqlite3_close(db_);
    db_ = nullptr;
    const std::string stamp = std::to_string(
        std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
    for (const char* suffix : {"", "-wal", "-shm"})
      if (fs::exists(dir_ / (std::string("state.db") + suffix))) setAside(dir_ / (std::string("state.db") + suffix));
    openingRepairs_.push_back(dir_.string() + "/state.db is damaged (" + e.what() +
                              "): kept aside in lost+found/, and a new one started; the jobs are taken back from "
                              "their files");
    open();
  }
}

void StateStore::open() {
  if (sqlite3_open((dir_ / "state.db").c_str(), &db_) != SQLITE_OK)
    throw std::runtime_error("cannot open " + (dir_ / "state.db").string() + ": " + sqlite3_errmsg(db_));
  exec("PRAGMA journal_mode=WAL");
  exec("PRAGMA synchronous=FULL");
  {
    Statement check(db_, "PRAGMA quick_check");
    if (check.step() && check.text(0) != "ok") throw DamagedDatabase("state.db: quick_check: " + check.text(0));
  }
  exec("CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value INTEGER)");
  exec(
      "CREATE TABLE IF NOT EXISTS jobs(id TEXT PRIMARY KEY, sequence INTEGER, priority INTEGER, spec TEXT, "
      "state TEXT, error TEXT, submitted REAL, folded_units INTEGER, stop_units INTEGER, stop_reason TEXT)");
  // Added by the job life cycle; a state dir written before it gains them empty.
  addColumnIfMissing("jobs", "owner", "TEXT");
  addColumnIfMissing("jobs", "ended", "REAL");
  addColumnIfMissing("jobs", "archived", "INTEGER");
  addColumnIfMissing("jobs", "summary", "TEXT");
  addColumnIfMissing("jobs", "kernel", "TEXT");
  // Added by the scheduler (docs/farm.md "Scheduling"): a row written before gains the default
  // policy, not paused, not approved, and released (it had no dependencies).
  addColumnIfMissing("jobs", "policy", "TEXT");
  addColumnIfMissing("jobs", "paused", "INTEGER");
  addColumnIfMissing("jobs", "approved", "INTEGER");
  addColumnIfMissing("jobs", "released", "INTEGER");
  exec(
      "CREATE TABLE IF NOT EXISTS ledger(job_id TEXT, unit INTEGER, worker TEXT, paths INTEGER, rays INTEGER, "
      "light_hits INTEGER, dropped INTEGER, PRIMARY KEY(job_id, unit))");
  addColumnIfMissing("ledger", "build", "TEXT");
  exec("CREATE TABLE IF NOT EXISTS stamp(key TEXT PRIMARY KEY, value TEXT)");
  // Added with the events and webhooks (docs/api.md "Events").
  exec(
      "CREATE TABLE IF NOT EXISTS events(sequence INTEGER PRIMARY KEY, unix REAL, type TEXT, job TEXT, worker TEXT, "
      "owner TEXT, text TEXT)");
  exec("CREATE TABLE IF NOT EXISTS webhooks(url TEXT PRIMARY KEY, sequence INTEGER)");
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

fs::path StateStore::setAside(const fs::path& file) {
  const fs::path aside = dir_ / "lost+found";
  fs::create_directories(aside);
  std::string name = file.parent_path().filename() == "jobs" || file.parent_path() == dir_
                         ? file.filename().string()
                         : file.parent_path().filename().string() + "-" + file.filename().string();
  fs::path target = aside / name;
  for (int k = 1; fs::exists(target); ++k) target = aside / (name + "." + std::to_string(k));
  std::error_code ec;
  fs::rename(file, target, ec);
  return target;
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
    throwSqlite(db_, what);
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

std::map<std::string, uint64_t> StateStore::listAssets() {
  std::map<std::string, uint64_t> out;
  for (const auto& entry : fs::directory_iterator(dir_ / "assets"))
    if (entry.is_regular_file() && entry.path().filename().string().front() != '.')
      out[entry.path().filename().string()] = entry.file_size();
  return out;
}

std::optional<std::string> StateStore::loadAsset(const std::string& sha256) {
  try {
    return readAll(dir_ / "assets" / sha256);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

void StateStore::setAssetAside(const std::string& sha256, const std::string& why) {
  const fs::path file = dir_ / "assets" / sha256;
  std::lock_guard lock(mutex_);
  const fs::path target = setAside(file);
  spdlog::error("{}: {}: kept aside as {}; the asset counts as missing until a client uploads it again", file.string(),
                why, target.string());
}

void StateStore::appendEvent(const FarmEvent& e, size_t keep) {
  std::lock_guard lock(mutex_);
  Statement(db_,
            "INSERT OR REPLACE INTO events(sequence, unix, type, job, worker, owner, text) VALUES(?, ?, ?, ?, ?, ?, ?)")
      .bind(1, int64_t(e.sequence))
      .bind(2, e.unixSeconds)
      .bind(3, e.type)
      .bind(4, e.jobId)
      .bind(5, e.workerId)
      .bind(6, e.owner)
      .bind(7, e.text)
      .step();
  if (e.sequence > keep && e.sequence % 64 == 0)  // (trimmed now and then, not on every event)
    Statement(db_, "DELETE FROM events WHERE sequence <= ?").bind(1, int64_t(e.sequence - keep)).step();
}

std::vector<FarmEvent> StateStore::loadEvents() {
  std::lock_guard lock(mutex_);
  std::vector<FarmEvent> out;
  Statement s(db_, "SELECT sequence, unix, type, job, worker, owner, text FROM events ORDER BY sequence");
  while (s.step())
    out.push_back(FarmEvent{uint64_t(s.integer(0)), s.real(1), s.text(2), s.text(3), s.text(4), s.text(5), s.text(6)});
  return out;
}

std::optional<uint64_t> StateStore::webhookCursor(const std::string& url) {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT sequence FROM webhooks WHERE url = ?");
  s.bind(1, url);
  if (!s.step()) return std::nullopt;
  return uint64_t(s.integer(0));
}

void StateStore::setWebhookCursor(const std::string& url, uint64_t sequence) {
  std::lock_guard lock(mutex_);
  Statement(db_, "INSERT OR REPLACE INTO webhooks(url, sequence) VALUES(?, ?)")
      .bind(1, url)
      .bind(2, int64_t(sequence))
      .step();
}

void StateStore::removeAsset(const std::string& sha256) {
  std::error_code ignored;
  fs::remove(dir_ / "assets" / sha256, ignored);
}

void StateStore::insertJob(const StoredJob& job) {
  std::lock_guard lock(mutex_);
  fs::create_directories(jobDir(job.id));
  Statement(db_,
            "INSERT INTO jobs(id, sequence, priority, spec, state, error, submitted, folded_units, owner, "
            "ended, archived, policy, paused, approved, released) VALUES(?, ?, ?, ?, ?, ?, ?, 0, ?, 0, 0, ?, ?, ?, ?)")
      .bind(1, job.id)
      .bind(2, int64_t(job.sequence))
      .bind(3, int64_t(job.priority))
      .bind(4, specToJson(job.spec).dump())
      .bind(5, job.state)
      .bind(6, job.error)
      .bind(7, job.submittedUnixSeconds)
      .bind(8, job.owner)
      .bind(9, job.policy)
      .bind(10, int64_t(job.paused))
      .bind(11, int64_t(job.approved))
      .bind(12, int64_t(job.released))
      .step();
  if (job.id.rfind("job-", 0) == 0)
    Statement(db_,
              "INSERT INTO meta(key, value) VALUES('last_job', ?) "
              "ON CONFLICT(key) DO UPDATE SET value = max(value, excluded.value)")
        .bind(1, int64_t(std::stoull(job.id.substr(4))))
        .step();
  writeManifest(job);
}

void StateStore::writeManifest(const StoredJob& job) {
  const std::string text = manifestOf(job).dump();
  writeCheckedFile(jobDir(job.id) / "job.json", {text});
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
  // Renamed first: a crash from here on leaves a directory that says it was being deleted, never
  // one that looks like a job the database lost (recoverJobs finishes the deletion).
  const fs::path deleting = dir_ / "jobs" / (".deleting-" + jobId);
  std::error_code renamed;
  fs::rename(jobDir(jobId), deleting, renamed);
  inTransaction([&] {
    Statement(db_, "DELETE FROM ledger WHERE job_id = ?").bind(1, jobId).step();
    Statement(db_, "DELETE FROM jobs WHERE id = ?").bind(1, jobId).step();
  });
  std::error_code ignored;
  fs::remove_all(deleting, ignored);
}

std::vector<std::string> StateStore::recoverJobs() {
  std::vector<std::string> repairs;
  std::set<std::string> known;
  {
    std::lock_guard lock(mutex_);
    Statement s(db_, "SELECT id FROM jobs");
    while (s.step()) known.insert(s.text(0));
  }
  std::vector<fs::path> dirs;
  for (const auto& entry : fs::directory_iterator(dir_ / "jobs"))
    if (entry.is_directory()) dirs.push_back(entry.path());
  for (const fs::path& dir : dirs) {
    const std::string name = dir.filename().string();
    if (name.rfind(".deleting-", 0) == 0) {  // a deletion a crash cut short: finished now
      const std::string id = name.substr(std::string(".deleting-").size());
      if (known.count(id))
        inTransaction([&] {
          Statement(db_, "DELETE FROM ledger WHERE job_id = ?").bind(1, id).step();
          Statement(db_, "DELETE FROM jobs WHERE id = ?").bind(1, id).step();
        });
      std::error_code ignored;
      fs::remove_all(dir, ignored);
      continue;
    }
    if (known.count(name) || name.front() == '.') continue;
    std::string damage;
    const std::optional<std::string> manifest = readCheckedFile(dir / "job.json", damage);
    json j = manifest ? json::parse(*manifest, nullptr, false) : json();
    if (!manifest || j.is_discarded() || j.value("id", "") != name) {
      const fs::path target = setAside(dir);
      repairs.push_back(dir.string() + " has no row in state.db and no valid job.json (" +
                        (manifest ? "not the job's" : damage) + "): kept aside as " + target.string());
      continue;
    }
    StoredJob job;
    job.id = name;
    job.sequence = j.at("sequence").get<uint64_t>();
    job.priority = j.at("priority").get<int>();
    job.spec = specFromJson(j.at("spec"));
    job.state = "queued";
    job.owner = j.value("owner", "");
    job.submittedUnixSeconds = j.value("submitted", 0.0);
    job.kernel = j.value("kernel", "");
    job.policy = j.value("policy", "");
    job.released = true;  // as submitted, less its dependencies: the jobs it waited for may be gone
    insertJob(job);
    if (!job.kernel.empty()) updateJobKernel(job.id, job.kernel, false);
    repairs.push_back(dir.string() +
                      ": state.db had no row for it (a lost WAL or a damaged database?): taken back "
                      "from its files as submitted; its later priority, cancellation or end were not kept");
  }
  return repairs;
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

void StateStore::updateJobSchedule(const std::string& jobId, bool paused, bool approved, bool released) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET paused = ?, approved = ?, released = ? WHERE id = ?")
      .bind(1, int64_t(paused))
      .bind(2, int64_t(approved))
      .bind(3, int64_t(released))
      .bind(4, jobId)
      .step();
}

void StateStore::updateJobPolicy(const std::string& jobId, const std::string& policy) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET policy = ? WHERE id = ?").bind(1, policy).bind(2, jobId).step();
}

void StateStore::updateJobPriority(const std::string& jobId, int priority) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET priority = ? WHERE id = ?").bind(1, int64_t(priority)).bind(2, jobId).step();
}

void StateStore::updateJobKernel(const std::string& jobId, const std::string& kernel, bool inManifest) {
  std::lock_guard lock(mutex_);
  Statement(db_, "UPDATE jobs SET kernel = ? WHERE id = ?").bind(1, kernel).bind(2, jobId).step();
  if (!inManifest) return;
  // The manifest too, so a job taken back from its files (recoverJobs) keeps the bits of its units.
  std::string damage;
  const std::optional<std::string> text = readCheckedFile(jobDir(jobId) / "job.json", damage);
  json manifest = text ? json::parse(*text, nullptr, false) : json();
  if (manifest.is_discarded() || !manifest.is_object()) return;  // recoverJobs reports a damaged one
  manifest["kernel"] = kernel;
  writeCheckedFile(jobDir(jobId) / "job.json", {manifest.dump()});
}

std::vector<StateStore::StoredJob> StateStore::loadJobs() {
  std::lock_guard lock(mutex_);
  std::vector<StoredJob> out;
  Statement s(db_,
              "SELECT id, sequence, priority, spec, state, error, submitted, folded_units, "
              "coalesce(stop_units, -1), coalesce(stop_reason, ''), coalesce(owner, ''), coalesce(ended, 0), "
              "coalesce(archived, 0), coalesce(summary, ''), coalesce(kernel, ''), coalesce(policy, ''), "
              "coalesce(paused, 0), coalesce(approved, 0), coalesce(released, 1) FROM jobs ORDER BY sequence");
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
    j.kernel = s.text(14);
    j.policy = s.text(15);
    j.paused = s.integer(16) != 0;
    j.approved = s.integer(17) != 0;
    j.released = s.integer(18) != 0;
    out.push_back(std::move(j));
  }
  return out;
}

void StateStore::recordUnit(const std::string& jobId, const LedgerEntry& e, const std::vector<double>& sums) {
  const fs::path file = jobDir(jobId) / ("unit-" + std::to_string(e.unit) + ".bin");
  const std::string header = unitHeader(e, sums.size());
  writeCheckedFile(
      file, {header, std::string_view(reinterpret_cast<const char*>(sums.data()), sums.size() * sizeof(double))});
  std::lock_guard lock(mutex_);
  Statement(db_,
            "INSERT OR IGNORE INTO ledger(job_id, unit, worker, paths, rays, light_hits, dropped, build) "
            "VALUES(?, ?, ?, ?, ?, ?, ?, ?)")
      .bind(1, jobId)
      .bind(2, int64_t(e.unit))
      .bind(3, e.worker)
      .bind(4, int64_t(e.stats.paths))
      .bind(5, int64_t(e.stats.rays))
      .bind(6, int64_t(e.stats.lightHits))
      .bind(7, int64_t(e.stats.dropped))
      .bind(8, e.build)
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
  Statement s(db_,
              "SELECT unit, worker, paths, rays, light_hits, dropped, coalesce(build, '') FROM ledger WHERE job_id = ? "
              "ORDER BY unit");
  s.bind(1, jobId);
  while (s.step()) {
    LedgerEntry e;
    e.unit = uint64_t(s.integer(0));
    e.worker = s.text(1);
    e.stats.paths = uint64_t(s.integer(2));
    e.stats.rays = uint64_t(s.integer(3));
    e.stats.lightHits = uint64_t(s.integer(4));
    e.stats.dropped = uint64_t(s.integer(5));
    e.build = s.text(6);
    out.push_back(e);
  }
  return out;
}

StateStore::Reconciled StateStore::reconcileUnits(const std::string& jobId,
                                                  const std::function<bool(uint64_t)>& fileExpected,
                                                  const std::function<size_t(uint64_t)>& sumsOf) {
  std::map<uint64_t, LedgerEntry> rows;
  for (LedgerEntry& e : ledger(jobId)) rows.emplace(e.unit, std::move(e));
  std::set<uint64_t> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(jobDir(jobId), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("unit-", 0) == 0 && name.size() > 9 && name.compare(name.size() - 4, 4, ".bin") == 0 &&
        name.find_first_not_of("0123456789", 5) == name.size() - 4)
      files.insert(std::stoull(name.substr(5)));
  }
  std::set<uint64_t> units(files);
  for (const auto& [unit, row] : rows) units.insert(unit);
  std::lock_guard lock(mutex_);
  Reconciled out;
  std::vector<uint64_t> damaged, missing, adopted, corrected;
  std::string why;
  for (const uint64_t unit : units) {
    const auto row = rows.find(unit);
    const fs::path file = jobDir(jobId) / ("unit-" + std::to_string(unit) + ".bin");
    if (!fileExpected(unit)) {  // folded into the checkpoint or a stored frame: the row says enough
      if (row != rows.end()) out.units.push_back({row->second, std::nullopt});
      continue;
    }
    std::string damage;
    const std::optional<std::string> payload = files.count(unit) ? readCheckedFile(file, damage) : std::nullopt;
    std::optional<StoredUnit> stored = payload ? parseUnit(*payload, unit, sumsOf(unit)) : std::nullopt;
    if (!stored) {
      if (files.count(unit)) {
        why = payload ? "not this unit's file" : damage;
        damaged.push_back(unit);
        setAside(file);
      } else {
        missing.push_back(unit);
      }
      if (row != rows.end())
        Statement(db_, "DELETE FROM ledger WHERE job_id = ? AND unit = ?").bind(1, jobId).bind(2, int64_t(unit)).step();
      continue;
    }
    if (row == rows.end() || !sameEntry(row->second, stored->entry)) {
      (row == rows.end() ? adopted : corrected).push_back(unit);
      Statement(db_,
                "INSERT OR REPLACE INTO ledger(job_id, unit, worker, paths, rays, light_hits, dropped) "
                "VALUES(?, ?, ?, ?, ?, ?, ?)")
          .bind(1, jobId)
          .bind(2, int64_t(unit))
          .bind(3, stored->entry.worker)
          .bind(4, int64_t(stored->entry.stats.paths))
          .bind(5, int64_t(stored->entry.stats.rays))
          .bind(6, int64_t(stored->entry.stats.lightHits))
          .bind(7, int64_t(stored->entry.stats.dropped))
          .step();
    }
    out.units.push_back(std::move(*stored));
  }
  const std::string where = jobDir(jobId).string();
  if (!damaged.empty())
    out.repairs.push_back(unitList(damaged) + " of " + jobId + ": file damaged (" + why +
                          "): kept aside in lost+found/ and rendered again");
  if (!missing.empty())
    out.repairs.push_back(unitList(missing) + " of " + jobId + ": in the ledger but no file in " + where +
                          ": rendered again");
  if (!adopted.empty())
    out.repairs.push_back(unitList(adopted) + " of " + jobId +
                          ": a valid file but no ledger row (the database lost the commit): taken back");
  if (!corrected.empty())
    out.repairs.push_back(unitList(corrected) + " of " + jobId + ": ledger row corrected from the unit's file");
  return out;
}

void StateStore::writeCheckpoint(const std::string& jobId, const std::string& sensorBytes,
                                 const std::string& trackerBytes, uint64_t foldedUnits) {
  // The count of folded units travels inside the file with the sensor and the convergence
  // tracker, so the three can never disagree, whatever moment a crash picks.
  const uint64_t sensorSize = sensorBytes.size();
  writeCheckedFile(
      jobDir(jobId) / "sensor.bin",
      {std::string_view(reinterpret_cast<const char*>(&foldedUnits), sizeof foldedUnits),
       std::string_view(reinterpret_cast<const char*>(&sensorSize), sizeof sensorSize), sensorBytes, trackerBytes});
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

std::optional<StateStore::Checkpoint> StateStore::loadCheckpoint(const std::string& jobId, std::string* damage) {
  const fs::path file = jobDir(jobId) / "sensor.bin";
  if (!fs::exists(file)) return std::nullopt;
  std::string why;
  std::optional<std::string> read = readCheckedFile(file, why);
  bool valid = read.has_value();
  std::string bytes = valid ? std::move(*read) : std::string();
  uint64_t sensorSize = 0;
  if (valid && bytes.size() >= 2 * sizeof(uint64_t))
    std::memcpy(&sensorSize, bytes.data() + sizeof(uint64_t), sizeof sensorSize);
  if (valid && (bytes.size() < 2 * sizeof(uint64_t) || sensorSize > bytes.size() - 2 * sizeof(uint64_t))) {
    why = "inconsistent sizes";
    valid = false;
  }
  if (!valid) {
    setAside(file);
    if (damage) *damage = file.string() + " is damaged (" + why + "): kept aside in lost+found/";
    return std::nullopt;
  }
  Checkpoint c;
  std::memcpy(&c.foldedUnits, bytes.data(), sizeof(uint64_t));
  // Cut the payload in place rather than copy the sensor out of it (it is most of a checkpoint).
  c.trackerBytes = bytes.substr(2 * sizeof(uint64_t) + sensorSize);
  bytes.resize(2 * sizeof(uint64_t) + sensorSize);
  bytes.erase(0, 2 * sizeof(uint64_t));
  c.sensorBytes = std::move(bytes);
  return c;
}

}  // namespace lensfarm
