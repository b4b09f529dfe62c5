// Coordinator, the job life cycle (docs/farm.md "Job life cycle"): listing with filters,
// deleting, archiving, and the retention policy that deletes and archives ended jobs by age, so
// that the coordinator's memory and disk are bounded by its active jobs, not by its history.
//
// Invariants:
//  - A job is used outside Coordinator::mutex_ only under a JobPin (image(), checkpoint(), a
//    result being summed). Deleting and archiving wait until no pin is left, so no thread ever
//    reads a film (or a job) that was freed.
//  - Archiving stores the final image durably (JobArchive) before the row says archived, and the
//    row says so before the ledger rows, sensor.bin and unit files go: a crash at any point leaves
//    either the job as it was or the archived job (restore() finishes the removal).
//  - Deleting removes the job's rows in one transaction before its directory: a crash leaves
//    either the whole job or an orphan directory that the next start removes. A deleted job's id
//    is never issued again (StateStore::lastJobNumber).
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>

#include "common/util/byte_size.h"
#include "common/util/error.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/coordinator_records.h"
#include "coordinator/store/frame_store.h"
#include "coordinator/store/job_archive.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

namespace {
double unixNow() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }
}  // namespace

double parseDuration(const std::string& text, const std::string& flag) {
  static const std::regex form(R"(\s*(-?)([0-9]+(?:\.[0-9]*)?|\.[0-9]+)\s*([smhdw]?)\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, form))
    throw InputError(flag,
                     "expected a duration such as 7d, 12h, 30m, 3600s or 0 (a number with s, m, h, d or w), "
                     "got \"" +
                         text + "\"");
  if (!m[1].str().empty()) throw InputError(flag, "a duration cannot be negative, got \"" + text + "\"");
  static const std::map<std::string, double> unit = {{"", 1.0},     {"s", 1.0},     {"m", 60.0},
                                                     {"h", 3600.0}, {"d", 86400.0}, {"w", 604800.0}};
  const double seconds = std::stod(m[2].str()) * unit.at(m[3].str());
  if (!std::isfinite(seconds)) throw InputError(flag, "duration out of range: \"" + text + "\"");
  return seconds;
}

// ---- pins -----------------------------------------------------------------------------------

Coordinator::JobPin::JobPin(const Coordinator& coordinator, Job& job) : coordinator_(&coordinator), job_(&job) {
  if (!job.retention.pin()) {
    job_ = nullptr;
    throw FarmError(FarmError::Kind::kFailedPrecondition, job.definition.id + " is being deleted");
  }
}

Coordinator::JobPin::JobPin(JobPin&& other) noexcept : coordinator_(other.coordinator_), job_(other.job_) {
  other.job_ = nullptr;
}

Coordinator::JobPin& Coordinator::JobPin::operator=(JobPin&& other) noexcept {
  if (this != &other) {
    release();
    coordinator_ = other.coordinator_;
    job_ = other.job_;
    other.job_ = nullptr;
  }
  return *this;
}

Coordinator::JobPin::~JobPin() { release(); }

void Coordinator::JobPin::release() {
  if (!job_) return;
  MutexLock lock(coordinator_->mutex_);
  if (job_->retention.unpin()) coordinator_->changed_.notify_all();
  job_ = nullptr;
}

// ---- listing --------------------------------------------------------------------------------

std::vector<JobInfo> Coordinator::jobs(const JobFilter& filter) const {
  std::vector<JobInfo> out;
  for (JobInfo& info : jobs()) {
    if (!filter.states.empty() && !filter.states.count(info.state)) continue;
    if (!filter.owner.empty() && info.owner != filter.owner) continue;
    if (!filter.nameContains.empty() && info.sceneName.find(filter.nameContains) == std::string::npos) continue;
    out.push_back(std::move(info));
    if (filter.limit && out.size() == filter.limit) break;
  }
  return out;
}

// ---- deleting -------------------------------------------------------------------------------

void Coordinator::deleteJob(const std::string& jobId, bool force) {
  std::unique_ptr<Job> gone;  // freed outside the lock
  {
    MutexLock lock(mutex_);
    if (deletedJobs_.count(jobId)) throw FarmError(FarmError::Kind::kNotFound, "no job " + jobId + " (it was deleted)");
    Job& job = findJob(jobId);
    if (job.retention.deleting)
      throw FarmError(FarmError::Kind::kNotFound, "no job " + jobId + " (it is being deleted)");
    if (!isTerminal(job.progress.state)) {
      if (!force)
        throw FarmError(FarmError::Kind::kFailedPrecondition, jobId + " is " + jobStateName(job.progress.state) +
                                                                  ": cancel it first, or delete it with --force");
      end(job, JobState::kCancelled);
      spdlog::info("job {}: cancelled to be deleted", job.definition.id);
    }
    job.retention.deleting = true;  // no new pin; the scheduler leases nothing of an ended job
    lock.wait(changed_, [&] { return job.retention.mayDelete(); });
    revokeLeasesOf(job);
    const auto it = jobs_.find(jobId);
    gone = std::move(it->second);
    jobs_.erase(it);
    deletedJobs_.insert(jobId);
    notify(*gone, farm_event::kJobDeleted, "deleted");
    changed_.notify_all();  // watchers of the job see it gone
  }
  if (store_) store_->deleteJob(jobId);
  archive_->remove(jobId);
  frames_->removeJob(jobId);  // an animation's frames (without a state dir, in a temporary directory)
  spdlog::info("job {}: deleted", jobId);
}

// ---- archiving ------------------------------------------------------------------------------

std::string Coordinator::summaryOf(const Job& job) {
  nlohmann::json workers = nlohmann::json::object();
  for (const auto& [name, units] : job.progress.unitsByWorker) workers[name] = units;
  nlohmann::json builds = nlohmann::json::object();
  for (const auto& [build, units] : job.progress.unitsByBuild) builds[build] = units;
  return nlohmann::json{{"units", job.progress.unitsAdded},
                        {"samples_per_pixel", job.progress.samplesPerPixelDone},
                        {"paths", job.progress.stats.paths},
                        {"rays", job.progress.stats.rays},
                        {"light_hits", job.progress.stats.lightHits},
                        {"dropped", job.progress.stats.dropped},
                        {"truncated", job.progress.stats.truncated},
                        {"estimate_valid", job.progress.estimate.valid},
                        {"relative_rmse", job.progress.estimate.relativeRmse},
                        {"workers", workers},
                        {"builds", builds}}
      .dump();
}

void Coordinator::restoreSummary(Job& job, const std::string& summary) {
  const nlohmann::json j = nlohmann::json::parse(summary.empty() ? "{}" : summary);
  job.progress.unitsAdded = j.value("units", uint64_t(0));
  job.progress.samplesPerPixelDone = j.value("samples_per_pixel", uint64_t(0));
  job.progress.stats.paths = j.value("paths", uint64_t(0));
  job.progress.stats.rays = j.value("rays", uint64_t(0));
  job.progress.stats.lightHits = j.value("light_hits", uint64_t(0));
  job.progress.stats.dropped = j.value("dropped", uint64_t(0));
  job.progress.stats.truncated = j.value("truncated", uint64_t(0));
  job.progress.estimate.valid = j.value("estimate_valid", false);
  job.progress.estimate.relativeRmse = j.value("relative_rmse", 0.0);
  if (j.contains("workers"))
    for (const auto& [name, units] : j["workers"].items()) job.progress.unitsByWorker[name] = units.get<uint64_t>();
  if (j.contains("builds"))
    for (const auto& [build, units] : j["builds"].items()) job.progress.unitsByBuild[build] = units.get<uint64_t>();
}

JobImage Coordinator::archivedImage(const Job& job) const {
  JobImage out;
  {
    MutexLock lock(mutex_);
    out.exposure = job.definition.settings.exposure;
  }
  std::optional<Image> image = archive_->load(job.definition.id, &out.metadata);
  if (!image)
    throw FarmError(FarmError::Kind::kNotFound, job.definition.id + " is archived but its image is missing (" +
                                                    archive_->pathOf(job.definition.id).string() + ")");
  out.image = std::move(*image);
  return out;
}

JobInfo Coordinator::archiveJob(const std::string& jobId) {
  Job* job;
  {
    MutexLock lock(mutex_);
    Job& found = findJobNotArchiving(lock, jobId);  // one archiving at a time per job
    if (found.retention.deleting) throw FarmError(FarmError::Kind::kFailedPrecondition, jobId + " is being deleted");
    if (!isTerminal(found.progress.state))
      throw FarmError(FarmError::Kind::kFailedPrecondition,
                      jobId + " is " + jobStateName(found.progress.state) +
                          ": only a job that ended can be archived (cancel it first)");
    if (found.retention.archived) return infoOf(found);
    found.retention.archiving = true;  // image() waits, checkpoint() skips it, deleteJob() waits
    lock.wait(changed_, [&] { return found.retention.mayFreeFilm(); });
    job = &found;
  }
  std::string summary;
  MemoryBudget::Reservation archived;  // without a state dir, the encoded image stays in memory
  try {
    MemoryBudget::Reservation memory = reserveImage(job->definition.settings, "archiving " + jobId);
    const JobImage image = developedImage(*job);
    archive_->store(jobId, image.image, image.metadata);
    if (!store_) archived = memory_->force(archive_->bytesInMemoryOf(jobId), jobId + "'s archived image");
    {
      MutexLock lock(mutex_);
      summary = summaryOf(*job);
    }
    if (store_) store_->markArchived(jobId, summary);
  } catch (...) {
    MutexLock lock(mutex_);
    job->retention.archiving = false;
    changed_.notify_all();
    throw;
  }
  MemoryBudget::Reservation released;  // returned once the film is freed (declared first: destroyed last)
  std::unique_ptr<Accumulator> freed;  // destroyed outside the lock
  MutexLock lock(mutex_);
  released = std::move(job->memory);
  freed = std::move(job->film);
  job->archiveMemory = std::move(archived);
  job->audit.provenance.clear();
  job->retention.archived = true;
  job->retention.archiving = false;
  touch(*job);
  spdlog::info("job {}: archived ({})", jobId, store_ ? archive_->pathOf(jobId).string() : std::string("in memory"));
  return infoOf(*job);
}

// ---- retention ------------------------------------------------------------------------------

void Coordinator::applyRetention() {
  const double now = unixNow();
  std::vector<std::string> toDelete, toArchive;
  {
    MutexLock lock(mutex_);
    lifecycleDue_ = false;
    for (const auto& [id, job] : jobs_) {
      if (!isTerminal(job->progress.state) || job->retention.deleting) continue;
      const double age = now - job->retention.endedUnixSeconds;
      if (options_.keepSeconds > 0.0 && age >= options_.keepSeconds)
        toDelete.push_back(id);
      else if (options_.archiveAfterSeconds >= 0.0 && age >= options_.archiveAfterSeconds &&
               !job->retention.filmReleased())
        toArchive.push_back(id);
    }
  }
  for (const std::string& id : toDelete) {
    try {
      deleteJob(id);
      spdlog::info("job {}: deleted by the retention policy (--keep {:g} s)", id, options_.keepSeconds);
    } catch (const std::exception& e) {
      spdlog::warn("retention: cannot delete {}: {}", id, e.what());
    }
  }
  for (const std::string& id : toArchive) {
    try {
      archiveJob(id);
    } catch (const std::exception& e) {
      spdlog::error("retention: cannot archive {}: {}", id, e.what());
    }
  }
}

// ---- asset garbage collection ------------------------------------------------------------------

size_t Coordinator::collectAssets() {
  if (options_.assetGraceSeconds < 0.0) return 0;
  const double now = std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
  std::vector<std::string> collected;
  uint64_t bytes = 0;
  MutexLock lock(mutex_);
  std::set<std::string> referenced;  // by every job the coordinator holds, archived ones too
  for (const auto& [id, job] : jobs_)
    for (const auto& [path, sha] : job->definition.spec.assets) referenced.insert(sha);
  const std::map<std::string, uint64_t> stored = assets_.sizes();
  for (auto it = assetUnreferencedSince_.begin(); it != assetUnreferencedSince_.end();)
    it = stored.count(it->first) && !referenced.count(it->first) ? std::next(it) : assetUnreferencedSince_.erase(it);
  for (const auto& [sha, size] : stored) {
    if (referenced.count(sha)) continue;
    const double since = assetUnreferencedSince_.emplace(sha, now).first->second;
    if (now - since < options_.assetGraceSeconds) continue;
    // Under the lock: a submission that refers to it checks again under the lock (submit()).
    assets_.remove(sha);
    assetUnreferencedSince_.erase(sha);
    collected.push_back(sha);
    bytes += size;
  }
  if (!collected.empty())
    spdlog::info("assets: collected {} ({}) no job has referred to for {:g} s (--asset-grace)", collected.size(),
                 formatBytes(bytes), options_.assetGraceSeconds);
  return collected.size();
}

void Coordinator::startLifecycle() {
  if (options_.keepSeconds <= 0.0 && options_.archiveAfterSeconds < 0.0 && options_.assetGraceSeconds < 0.0) return;
  applyRetention();  // at start-up, after restore()
  collectAssets();
  lifecycleThread_ = std::thread([this] { lifecycleLoop(); });
}

void Coordinator::stopLifecycle() {
  {
    MutexLock lock(mutex_);
    lifecycleStopping_ = true;
  }
  lifecycleWake_.notify_all();
  if (lifecycleThread_.joinable()) lifecycleThread_.join();
}

void Coordinator::lifecycleLoop() {
  // Often enough that a job outlives its limit by at most a quarter of it (and 10 s); a job
  // that ends wakes the loop at once (end()).
  double period = 10.0;
  for (const double limit : {options_.keepSeconds, options_.archiveAfterSeconds, options_.assetGraceSeconds})
    if (limit > 0.0) period = std::min(period, std::max(0.05, limit / 4.0));
  MutexLock lock(mutex_);
  while (!lifecycleStopping_) {
    lock.waitFor(lifecycleWake_, std::chrono::duration<double>(period), [&] {
      mutex_.assertHeld();
      return lifecycleStopping_ || lifecycleDue_;
    });
    if (lifecycleStopping_) break;
    lifecycleDue_ = false;
    lock.unlock();
    applyRetention();
    collectAssets();
    lock.lock();
  }
}

}  // namespace lensfarm
