#include "coordinator/web/dashboard.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <ctime>

#include "common/film/image.h"
#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "common/util/secret.h"

namespace lensfarm {

namespace {

using json = nlohmann::json;

json summaryOf(const JobInfo& info) {
  json j;
  j["id"] = info.id;
  j["state"] = jobStateName(info.state);
  j["priority"] = info.priority;
  j["scene"] = info.sceneName;
  j["owner"] = info.owner;
  j["archived"] = info.archived;  // its final image is served; its sensor was freed
  // Scheduling (docs/farm.md "Scheduling").
  j["paused"] = info.paused;
  j["approved"] = info.approved;
  j["waiting_for"] = info.waitingFor;
  j["deadline_outlook"] = info.deadlineOutlook;
  {
    json after = json::array();
    for (const Dependency& d : info.policy.after) after.push_back(dependencyText(d));
    j["policy"] = {
        {"after", after},
        {"require_tags", info.policy.requireTags},
        {"prefer_tags", info.policy.preferTags},
        {"audit_require_tags", info.policy.auditRequireTags},
        {"max_workers", info.policy.maxWorkers ? json(*info.policy.maxWorkers) : json(nullptr)},
        {"share_weight", info.policy.shareWeight},
        {"max_unit_failures", info.policy.maxUnitFailures ? json(*info.policy.maxUnitFailures) : json(nullptr)},
        {"max_worker_failures", info.policy.maxWorkerFailures ? json(*info.policy.maxWorkerFailures) : json(nullptr)},
        {"unit_time_limit_seconds",
         info.policy.unitTimeLimitSeconds ? json(*info.policy.unitTimeLimitSeconds) : json(nullptr)},
        {"on_failure", info.policy.onFailure == OnFailure::kPause ? "pause" : "fail"}};
  }
  j["width"] = info.width;
  j["height"] = info.height;
  j["spp_done"] = info.samplesPerPixelDone;
  // A job that runs to a target error or a deadline has only the internal cap: no total to show.
  const bool capped = info.samplesPerPixelTotal < kMaxSamplesPerPixel;
  j["spp_total"] = capped ? json(info.samplesPerPixelTotal) : json(nullptr);
  j["units_done"] = info.unitsDone;
  j["units_total"] = capped ? json(info.unitsTotal) : json(nullptr);
  j["progress"] = info.progressFraction;  // toward the nearest stop: samples, target error or deadline
  j["stalled_reason"] = info.stalledReason;
  j["samples_per_second"] = info.elapsedSeconds > 0 ? double(info.stats.paths) / info.elapsedSeconds : 0.0;
  j["rays_per_second"] = info.raysPerSecond();
  j["estimated_error"] = info.estimatedRelativeError >= 0 ? json(info.estimatedRelativeError) : json(nullptr);
  j["target_error"] = info.targetError;
  j["elapsed_seconds"] = info.elapsedSeconds;
  j["remaining_seconds"] = info.remainingSeconds;
  j["seconds_to_target"] = info.secondsToTarget;
  j["time_limit_seconds"] = info.timeLimitSeconds;
  j["workers_busy"] = info.workersBusy;
  j["error"] = info.error;
  j["stop_reason"] = info.stopReason;
  j["submitted_unix_seconds"] = info.submittedUnixSeconds;
  j["version"] = info.version;
  j["audits_passed"] = info.auditsPassed;  // the cross-worker audit (docs/farm.md "Audit")
  j["audits_failed"] = info.auditsFailed;
  j["audits_pending"] = info.auditsPending;
  j["units_rerendered"] = info.unitsRerendered;
  j["tile_size"] = info.tileSize;  // 0: passes over the whole frame (docs/farm.md "Tiles and passes")
  uint64_t complete = 0;
  for (const JobInfo::Frame& f : info.frames) complete += f.complete();
  j["frames_total"] = info.frames.size();  // 0 for a still
  j["frames_complete"] = complete;
  return j;
}

}  // namespace

std::string jobDetailJson(const JobInfo& info, const std::vector<ErrorPoint>& errorHistory) {
  json j = summaryOf(info);
  json frames = json::array();  // an animation's frames: number, tiles in, tiles a frame
  for (const JobInfo::Frame& f : info.frames) frames.push_back({f.number, f.tilesDone, f.tilesTotal});
  j["frames"] = frames;
  j["scene_hash"] = info.sceneHash;
  j["effects"] = info.effects;
  j["kernel"] = info.kernel;
  j["builds"] = info.builds;
  j["light_hit_fraction"] = info.lightHitFraction();
  j["dropped_samples"] = info.stats.dropped;
  json history = json::array();
  for (const ErrorPoint& p : errorHistory)
    history.push_back(json{{"t", p.elapsedSeconds}, {"error", p.relativeError}, {"spp", p.samplesPerPixel}});
  j["error_history"] = history;
  json events = json::array();
  for (const JobInfo::Event& e : info.events) events.push_back(json{{"unix_seconds", e.unixSeconds}, {"text", e.text}});
  j["events"] = events;
  return j.dump();
}

std::string workerListJson(const std::vector<WorkerView>& workers) {
  json list = json::array();
  for (const WorkerView& w : workers) {
    list.push_back(json{{"id", w.id},
                        {"name", w.info.name},
                        {"cores", w.info.threads},
                        {"current_job", w.currentJobId},
                        {"current_unit", w.currentUnit ? json(*w.currentUnit) : json(nullptr)},
                        {"units_done", w.unitsDone},
                        {"samples_per_second", w.samplesPerSecond},
                        {"seconds_since_heartbeat", w.secondsSinceHeartbeat},
                        {"renderer_version", w.info.rendererVersion},
                        {"state", workerStateName(w.state)},
                        {"seconds_in_state", w.secondsInState},
                        {"failures", w.failures},
                        {"blocklisted_jobs", w.blocklistedJobs},
                        {"state_reason", w.stateReason},
                        {"attached", w.attached},
                        {"audits_passed", w.auditsPassed},
                        {"audits_rendered", w.auditsRendered},
                        {"credential", w.info.credential},
                        {"kernels", w.info.kernels},
                        {"build", w.info.build},
                        {"cpu", w.info.cpu},
                        {"quarantined", w.quarantined},
                        {"quarantine_reason", w.quarantineReason}});
  }
  return json{{"workers", list}}.dump();
}

Dashboard::Access Dashboard::access(const std::string& header) const {
  if (!token_) return Access::kFull;
  const std::string prefix = "Bearer ";
  if (header.rfind(prefix, 0) != 0) return Access::kNone;
  const std::string given = header.substr(prefix.size());
  // Both comparisons always run, so the time taken does not tell which token was close.
  const bool client = equalSecrets(given, *token_);
  const bool viewer = viewerToken_ && equalSecrets(given, *viewerToken_);
  const std::optional<User> user = users_.empty() ? std::nullopt : userOfToken(users_, given);
  const bool person = user && !user->expired(int64_t(std::time(nullptr)));
  return client ? Access::kFull : (viewer || person) ? Access::kRead : Access::kNone;
}

std::optional<User> Dashboard::userOf(const std::string& header) const {
  const std::string prefix = "Bearer ";
  if (users_.empty() || header.rfind(prefix, 0) != 0) return std::nullopt;
  std::optional<User> user = userOfToken(users_, header.substr(prefix.size()));
  if (user && user->expired(int64_t(std::time(nullptr)))) return std::nullopt;
  return user;
}

std::string Dashboard::jobsJson() const {
  json list = json::array();
  for (const JobInfo& info : coordinator_.jobs()) list.push_back(summaryOf(info));
  return json{{"jobs", list}}.dump();
}

std::string Dashboard::jobJson(const std::string& jobId) const {
  const JobInfo info = coordinator_.job(jobId);  // FarmError kNotFound for an unknown job
  return jobDetailJson(info, coordinator_.errorHistory(jobId));
}

std::string Dashboard::workersJson() const { return workerListJson(coordinator_.workers()); }

Dashboard::Png Dashboard::snapshot(const std::string& jobId, std::optional<double> ev, int maxSide) const {
  const uint64_t version = coordinator_.job(jobId).version;  // before the image: never newer than it
  JobImage image = coordinator_.image(jobId);
  if (ev) image.exposure.ev = *ev;
  // A box filter keeps the mean luminance, so the automatic exposure matches the download's.
  const Image preview = downscaleToFit(image.image, std::clamp(maxSide, 16, 1024));
  return Png{encodePng(preview, image.exposure), preview.width, preview.height,
             image.metadata.samplesPerPixel,     version,       image.exposure.ev};
}

std::string Dashboard::exr(const std::string& jobId) const {
  const JobImage image = coordinator_.image(jobId);
  return encodeExr(image.image, image.metadata);
}

Dashboard::Png Dashboard::png(const std::string& jobId, std::optional<double> ev) const {
  const uint64_t version = coordinator_.job(jobId).version;
  JobImage image = coordinator_.image(jobId);
  if (ev) image.exposure.ev = *ev;
  return Png{encodePng(image.image, image.exposure), image.image.width, image.image.height,
             image.metadata.samplesPerPixel,         version,           image.exposure.ev};
}

std::string Dashboard::cancel(const std::string& jobId) { return summaryOf(coordinator_.cancel(jobId)).dump(); }

std::string Dashboard::pause(const std::string& jobId) { return summaryOf(coordinator_.pauseJob(jobId)).dump(); }
std::string Dashboard::resume(const std::string& jobId) { return summaryOf(coordinator_.resumeJob(jobId)).dump(); }
std::string Dashboard::approve(const std::string& jobId) { return summaryOf(coordinator_.approveJob(jobId)).dump(); }

std::string Dashboard::setPriority(const std::string& jobId, int priority) {
  return summaryOf(coordinator_.setPriority(jobId, priority)).dump();
}

}  // namespace lensfarm
