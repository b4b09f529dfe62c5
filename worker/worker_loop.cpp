#include "worker/worker_loop.h"

#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <functional>

#include "common/farm/job_scene.h"
#include "common/farm/memory_estimate.h"
#include "common/render/build_identity.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "common/util/trace_kernel.h"
#include "common/util/version.h"

namespace lensfarm {

namespace {
constexpr size_t kJobsKept = 2;  // loaded scenes kept for reuse
}

WorkerLoop::WorkerLoop(CoordinatorLink& link, WorkerOptions options)
    : link_(link), options_(std::move(options)), assets_(options_.cacheDir) {}

WorkerLoop::~WorkerLoop() {
  stopNow();
  if (heartbeat_.joinable()) heartbeat_.join();
}

void WorkerLoop::stop() {
  stopping_ = true;
  wake_.notify_all();
}

void WorkerLoop::stopNow() {
  stopNow_ = true;
  cancelUnit_ = true;
  stop();
}

void WorkerLoop::sleepFor(double seconds) {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return stopping_.load(); });
}

std::string WorkerLoop::workerId() {
  std::lock_guard lock(mutex_);
  return workerId_;
}

void WorkerLoop::heartbeatLoop() {
  while (!stopNow_) {
    std::string id;
    std::vector<uint64_t> leases;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::duration<double>(heartbeatInterval_), [&] { return stopNow_.load(); });
      if (stopNow_ || (stopping_ && !currentLease_)) return;
      id = workerId_;
      if (currentLease_) leases.push_back(*currentLease_);
    }
    if (id.empty()) continue;
    try {
      for (uint64_t revoked : link_.heartbeat(id, leases)) {
        std::lock_guard lock(mutex_);
        if (currentLease_ == revoked && !uploading_) {
          spdlog::warn("lease {} revoked by the coordinator; abandoning the unit", revoked);
          cancelUnit_ = true;
        }
      }
    } catch (const FarmError& e) {
      if (e.kind() == FarmError::Kind::kUnknownWorker) {
        std::lock_guard lock(mutex_);
        workerId_.clear();  // the coordinator forgot us (restart): register again
        cancelUnit_ = true;
      }
    } catch (const LinkUnavailable&) {
      // The lease loop notices and backs off; the lease may lapse meanwhile.
    }
  }
}

void WorkerLoop::prefetch(const std::string& jobId) {
  try {
    const JobSpec spec = link_.jobSpec(jobId);
    uint64_t bytes = 0;
    for (const auto& [path, sha] : spec.assets)
      bytes += assets_.get(sha, [&](const std::string& h) { return link_.asset(h); }).size();
    spdlog::info("prefetched the {} asset(s) of {} ({:.2f} MB) into the cache", spec.assets.size(), jobId,
                 double(bytes) / 1e6);
  } catch (const FarmError& e) {  // (it ended, or was deleted, meanwhile: its units will not come)
    spdlog::warn("prefetch of {}: {}", jobId, e.what());
  }
}

std::shared_ptr<WorkerLoop::PreparedJob> WorkerLoop::prepare(const LeaseGrant& grant) {
  // An animation's frames are scenes of their own (keyframes evaluated at the frame,
  // docs/scene-format.md "Animation"): loaded per job and frame; a still's frame is always 0.
  // A job's kernel is pinned before its first lease, so it is one per job in practice; it is in the
  // key all the same, as the scene's traversal depends on it.
  const std::string key = grant.jobId + "@" + std::to_string(grant.unit.frame) + "@" + grant.kernel;
  if (auto it = jobs_.find(key); it != jobs_.end()) return it->second;
  const JobSpec spec = link_.jobSpec(grant.jobId);
  std::map<std::string, std::string> files;
  // Each asset is fetched once per cache (memory, then --cache-dir), however many jobs share it.
  for (const auto& [path, sha] : spec.assets)
    files[path] = assets_.get(sha, [&](const std::string& h) {
      std::string bytes = link_.asset(h);
      spdlog::info("fetched asset {} ({}, {:.2f} MB)", path, h.substr(0, 12), double(bytes.size()) / 1e6);
      return bytes;
    });
  auto job = std::make_shared<PreparedJob>();
  const AssetReader reader = [&](const std::string& path) -> std::optional<std::string> {
    auto it = files.find(path);
    if (it == files.end()) return std::nullopt;
    return it->second;
  };
  JobSceneOptions options;
  if (spec.frames) options.frame = double(grant.unit.frame);
  job->scene = jobScene(spec, reader, options);
  if (job->scene.hash != grant.sceneHash)
    throw InputError(spec.sceneName, "scene hash " + job->scene.hash + " differs from the job's " + grant.sceneHash);
  if (!grant.kernel.empty()) {  // one this machine cannot run is refused by RayCaster (InputError)
    job->scene.render.kernel = kernelNamed(grant.kernel);
    if (!job->scene.render.kernel)
      throw InputError("Lease.kernel", "unknown traversal kernel \"" + logText(grant.kernel.substr(0, 32)) + "\"");
  }
  job->kernel = kernelName(job->scene.render.kernel.value_or(machineBestKernel()));
  job->renderScene = std::make_unique<RenderScene>(job->scene);
  if (jobs_.size() >= kJobsKept) {
    jobs_.erase(jobOrder_.front());
    jobOrder_.pop_front();
  }
  jobs_[key] = job;
  jobOrder_.push_back(key);
  spdlog::info("loaded {} for {}: {}x{}, {} triangles", spec.sceneName, grant.jobId, job->scene.render.width,
               job->scene.render.height, storedTriangles(job->scene));
  return job;
}

namespace {

// Retries back off exponentially (0.1 s, doubling, up to the cap). A streak of failures is logged
// at warn when it starts, when its kind changes and once a minute; the retries between at debug;
// its end at info.
class Backoff {
 public:
  Backoff(double capSeconds, std::function<void(double)> sleep) : cap_(capSeconds), sleep_(std::move(sleep)) {}

  void failed(const char* what, const std::exception& e) {
    delay_ = std::min(cap_, delay_ > 0 ? delay_ * 2 : 0.1);
    const auto now = std::chrono::steady_clock::now();
    if (failures_++ == 0) streakStart_ = now;
    if (failures_ == 1 || kind_ != what || now - lastWarn_ >= std::chrono::seconds(60)) {
      spdlog::warn("{}: {}; retrying (attempt {}, every {:.1f} s at most)", what, e.what(), failures_, cap_);
      lastWarn_ = now;
    } else {
      spdlog::debug("{}: {}; retrying in {:.1f} s", what, e.what(), delay_);
    }
    kind_ = what;
    sleep_(delay_);
  }

  void recovered() {
    if (failures_ > 0)
      spdlog::info("coordinator reachable again after {} failed attempts over {:.1f} s", failures_,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - streakStart_).count());
    failures_ = 0;
    delay_ = 0.0;
    kind_.clear();
  }

 private:
  double cap_, delay_ = 0.0;
  std::function<void(double)> sleep_;
  uint64_t failures_ = 0;
  std::string kind_;
  std::chrono::steady_clock::time_point streakStart_, lastWarn_;
};

}  // namespace

void WorkerLoop::run() {
  heartbeat_ = std::thread([this] { heartbeatLoop(); });
  tbb::task_arena arena{int(std::max(1u, options_.threads))};
  Backoff backoff(options_.maxBackoffSeconds, [this](double seconds) { sleepFor(seconds); });
  // The last moment this worker had a unit (leased or just finished): --idle-exit counts from it,
  // through an idle farm and an unreachable coordinator alike.
  auto lastBusy = std::chrono::steady_clock::now();
  while (!stopping_) {
    {
      std::lock_guard lock(mutex_);
      if (currentLease_) lastBusy = std::chrono::steady_clock::now();
      currentLease_.reset();
      uploading_ = false;
    }
    const double idle = std::chrono::duration<double>(std::chrono::steady_clock::now() - lastBusy).count();
    if (options_.idleExitSeconds > 0 && idle >= options_.idleExitSeconds) {
      spdlog::info("no work for {:.0f} s (--idle-exit): leaving", idle);
      break;
    }
    try {
      if (workerId().empty()) {
        registerNow();
        backoff.recovered();
      }
      const std::string id = workerId();
      const std::optional<LeaseGrant> grant = link_.lease(id, options_.leaseWaitSeconds);
      backoff.recovered();
      if (!grant) {
        if (const std::string job = link_.takePrefetch(); !job.empty()) prefetch(job);
        continue;  // the coordinator already waited for work
      }
      lastBusy = std::chrono::steady_clock::now();
      serve(id, *grant, arena);
    } catch (const LinkUnavailable& e) {
      backoff.failed("coordinator unavailable", e);
    } catch (const CorruptAsset& e) {
      backoff.failed("asset transfer", e);
    } catch (const FarmError& e) {
      if (e.kind() == FarmError::Kind::kUnknownWorker) {
        std::lock_guard lock(mutex_);
        workerId_.clear();  // register again at once
        continue;
      }
      if (workerId().empty() || e.kind() == FarmError::Kind::kUnauthenticated) {
        // Registration refused (versions differ) or the token is wrong: retrying cannot help.
        stopNow();
        if (heartbeat_.joinable()) heartbeat_.join();
        throw;
      }
      backoff.failed("coordinator refused", e);
    } catch (const std::exception& e) {
      backoff.failed("unexpected failure", e);  // keep serving the farm; the lease lapses and moves on
    }
  }
  stopNow_ = true;
  wake_.notify_all();
  if (heartbeat_.joinable()) heartbeat_.join();
  link_.leave();  // a clean stop: shown as left, not lost
}

void WorkerLoop::registerNow() {
  std::vector<std::string> kernels;
  for (TraceKernel k : machineKernels()) kernels.push_back(kernelName(k));
  WorkerInfo info{options_.name,
                  options_.threads,
                  kProtocolVersion,
                  kRendererVersion,
                  options_.maxMemoryBytes,
                  /*credential: the coordinator knows it from the token*/ {},
                  std::move(kernels),
                  buildIdentity(),
                  cpuModel(),
                  options_.tags};
  const Registration r = link_.registerWorker(info);
  std::lock_guard lock(mutex_);
  workerId_ = r.workerId;
  heartbeatInterval_ = r.heartbeatIntervalSeconds;
  ++counters_.registrations;
  spdlog::info("registered as {} ({} threads)", r.workerId, options_.threads);
}

void WorkerLoop::serve(const std::string& id, const LeaseGrant& grant, tbb::task_arena& arena) {
  spdlog::debug("leased unit {} of {} (lease {}, samples {}..{})", grant.unit.index, grant.jobId, grant.leaseId,
                grant.unit.firstSample, grant.unit.firstSample + grant.unit.sampleCount);
  const auto refuse = [&](const std::string& what) {
    spdlog::error("cannot render {}: {}", grant.jobId, what);
    link_.reportFailure(id, grant.leaseId, grant.jobId, what);
  };
  std::shared_ptr<PreparedJob> job;
  try {
    job = prepare(grant);
  } catch (const InputError& e) {
    return refuse(e.what());
  } catch (const std::bad_alloc&) {
    return refuse("out of memory loading the scene on " + options_.name);
  }
  // A unit this worker cannot hold is refused with a report, before it allocates anything. A
  // coordinator that knows the worker's limit (WorkerInfo::maxUnitMemoryBytes) never leases
  // one; this guards against one that does not.
  const MemoryEstimate memory =
      workerJobMemory(job->scene.render, storedTriangles(job->scene), sceneDataBytes(job->scene));
  if (options_.maxMemoryBytes > 0 && memory.total() > options_.maxMemoryBytes)
    return refuse(overBudgetMessage(job->scene.render, memory, "worker", options_.maxMemoryBytes,
                                    "LENSFARM_MAX_JOB_MEMORY, else 3/4 of " + options_.name + "'s memory"));
  {
    std::lock_guard lock(mutex_);
    currentLease_ = grant.leaseId;
    cancelUnit_ = stopNow_.load();  // a stopNow() during loading still counts
  }
  UnitResult result = resultForLease(id, grant);
  result.kernel = job->kernel;
  const auto start = std::chrono::steady_clock::now();
  bool complete = false;
  try {
    arena.execute(
        [&] { complete = renderUnit(*job->renderScene, grant.unit, result.buffer, result.stats, &cancelUnit_); });
  } catch (const std::bad_alloc&) {
    return refuse("out of memory for a unit buffer (estimated " + memory.describe() + ") on " + options_.name);
  }
  result.renderSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++counters_.unitsRendered;
  if (!complete) {
    ++counters_.unitsAbandoned;
    spdlog::info("unit {} of {}: abandoned after {:.2f} s ({})", grant.unit.index, grant.jobId, result.renderSeconds,
                 stopNow_ ? "stopping" : "lease revoked");
    return;
  }
  {
    std::lock_guard lock(mutex_);
    uploading_ = true;
  }
  deliver(grant, result);
}

void WorkerLoop::deliver(const LeaseGrant& grant, const UnitResult& result) {
  // A unit is worth keeping: retry the upload through network trouble while the lease may still
  // be valid, then give it up (the coordinator re-leases it).
  for (double wait = 0.1;; wait *= 2) {
    try {
      const bool accepted = link_.upload(result);
      if (accepted) ++counters_.unitsAccepted;
      spdlog::info("unit {} of {}: {} samples in {:.2f} s, {:.1f} MB uploaded, {}", grant.unit.index, grant.jobId,
                   result.stats.paths, result.renderSeconds, double(result.buffer.sums.size() * sizeof(double)) / 1e6,
                   accepted ? "accepted" : "a duplicate (already counted)");
      return;
    } catch (const FarmError& e) {
      if (e.kind() == FarmError::Kind::kUnknownWorker) throw;
      ++counters_.unitsAbandoned;
      // A revoked lease is routine: the job stopped (target, deadline, cancel) or the unit lapsed
      // and went to another worker. Anything else is worth a warning.
      if (e.kind() == FarmError::Kind::kFailedPrecondition)
        spdlog::info("unit {} of {} no longer wanted: {}", grant.unit.index, grant.jobId, e.what());
      else
        spdlog::warn("upload of unit {} of {} refused: {}", grant.unit.index, grant.jobId, e.what());
      return;
    } catch (const LinkUnavailable& e) {
      if (stopNow_ || wait > grant.deadlineSeconds) throw;
      spdlog::warn("upload of unit {} failed: {}; retrying in {:.1f} s", grant.unit.index, e.what(), wait);
      sleepFor(std::min(wait, options_.maxBackoffSeconds));
    }
  }
}

}  // namespace lensfarm
