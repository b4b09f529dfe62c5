#include "client/progress_display.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include <fmt/format.h>

#include "common/film/convergence.h"
#include "common/scene/scene_loader.h"

namespace lensfarm::cli {

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

double nowUnix() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

bool isFinished(v1::JobState state) {
  return state == v1::JOB_STATE_DONE || state == v1::JOB_STATE_CANCELLED || state == v1::JOB_STATE_FAILED;
}

// "deadline 0:12 of 1:00": the time since submission (while running; the elapsed time once
// finished), within the job's deadline.
std::string deadlineText(const v1::JobStatus& s, double nowUnixSeconds) {
  const auto& p = s.progress();
  const double limit = p.time_limit_seconds();
  const double used = isFinished(s.state()) ? p.elapsed_seconds() : nowUnixSeconds - s.submitted_unix_seconds();
  return fmt::format("deadline {} of {}", formatDuration(std::clamp(used, 0.0, limit)), formatDuration(limit));
}

}  // namespace

std::string formatDuration(double seconds) {
  const long s = long(std::max(0.0, seconds) + 0.5);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

const char* stateName(v1::JobState state) {
  switch (state) {
    case v1::JOB_STATE_QUEUED: return "queued";
    case v1::JOB_STATE_RUNNING: return "running";
    case v1::JOB_STATE_DONE: return "done";
    case v1::JOB_STATE_CANCELLED: return "cancelled";
    case v1::JOB_STATE_FAILED: return "failed";
    default: return "unknown";
  }
}

bool hasSampleCap(const v1::JobProgress& p) { return p.samples_per_pixel_total() < kMaxSamplesPerPixel; }

std::string samplesText(const v1::JobProgress& p) {
  if (!hasSampleCap(p)) return std::to_string(p.samples_per_pixel_done());
  return std::to_string(p.samples_per_pixel_done()) + "/" + std::to_string(p.samples_per_pixel_total());
}

std::string timeLeftText(const v1::JobStatus& s) {
  const auto& p = s.progress();
  // No worker renders it (the reason is in stalled_reason): a time left would only grow.
  if (!isFinished(s.state()) && !p.stalled_reason().empty()) return "stalled";
  // The coordinator's remaining time is the nearest of: units left at the rate so far (without a
  // cap of the job's own, the internal one: meaningless), the projected time to the target error
  // and the time to the deadline.
  const bool known = isFinished(s.state()) || p.time_limit_seconds() > 0.0 ||
                     (p.target_error() > 0.0 && p.estimated_relative_error() >= 0.0) ||
                     (hasSampleCap(p) && p.units_done() > 0);
  return known ? formatDuration(p.remaining_seconds()) : "estimating";
}

std::string convergenceText(const v1::JobProgress& p, double watchTarget) {
  const double estimate = p.estimated_relative_error();
  const double target = p.target_error() > 0.0 ? p.target_error() : watchTarget;
  // Negative: unknown (fewer than two units, or an image black so far); never shown as a number.
  if (estimate < 0.0)
    return target > 0.0 ? fmt::format("err unknown (target {:.2f} %)", 100.0 * target) : "err unknown";
  std::string text = fmt::format("err {:.2f} %", 100.0 * estimate);
  if (target > 0.0) {
    const double eta =
        p.target_error() > 0.0 ? p.seconds_to_target() : secondsToTarget(estimate, target, p.elapsed_seconds());
    if (estimate <= target)
      text += fmt::format(" (target {:.2f} % reached)", 100.0 * target);
    else if (!p.stop_reason().empty())  // finished short of it: nothing to project
      text += fmt::format(" (target {:.2f} %)", 100.0 * target);
    else
      text += fmt::format(" (target {:.2f} % in ~{})", 100.0 * target, formatDuration(eta));
  }
  return text;
}

std::string progressLine(const v1::JobStatus& s, double watchTarget, double nowUnixSeconds) {
  const auto& p = s.progress();
  std::string line =
      fmt::format("{} {} spp  {}", stateName(s.state()), samplesText(p), convergenceText(p, watchTarget));
  if (p.time_limit_seconds() > 0.0) line += "  " + deadlineText(s, nowUnixSeconds);
  if (s.frames_size() > 0) {  // an animation: frames complete of the range
    int complete = 0;
    for (const v1::FrameStatus& f : s.frames()) complete += f.complete();
    line += fmt::format("  frames {}/{}", complete, s.frames_size());
  }
  // Until a unit is in, there is no rate and no time left to show, only that they are coming.
  const bool noData = !isFinished(s.state()) && p.units_done() == 0;
  if (noData)
    line += "  estimating";
  else
    line += fmt::format("  {:.2f} Mrays/s", p.rays_per_second() / 1e6);
  line += fmt::format("  {} busy  {} elapsed", p.workers_busy(), formatDuration(p.elapsed_seconds()));
  if (!noData) {
    const std::string left = timeLeftText(s);
    line += "  " + (left == "estimating" || left == "stalled" ? left : left + " left");
  }
  return line;
}

ProgressDisplay::ProgressDisplay(bool enabled, bool toTerminal, double watchTarget, double plainEverySeconds)
    : enabled_(enabled), terminal_(toTerminal), watchTarget_(watchTarget), plainEvery_(plainEverySeconds) {}

void ProgressDisplay::update(const v1::JobStatus& status) {
  if (!enabled_) return;
  const double t = now();
  const auto& p = status.progress();
  if (t - lastDraw_ < (terminal_ ? 0.1 : plainEvery_) && !isFinished(status.state())) return;
  lastDraw_ = t;
  // The bar shows whichever stopping rule is nearest (samples, target error or deadline), as the
  // coordinator computes it for every client (JobProgress.progress_fraction).
  const double fraction = status.state() == v1::JOB_STATE_DONE ? 1.0 : p.progress_fraction();
  const std::string line = progressLine(status, watchTarget_, nowUnix());
  if (terminal_) {
    const int width = 30;
    std::string bar(size_t(std::clamp(fraction, 0.0, 1.0) * width), '=');
    bar.resize(width, ' ');
    const std::string text = "[" + bar + "] " + line;
    const std::string blank(lastWidth_ > text.size() ? lastWidth_ - text.size() : 0, ' ');
    std::fprintf(stderr, "\r%s%s", text.c_str(), blank.c_str());
    lastWidth_ = text.size();
    drawn_ = true;
  } else {
    std::fprintf(stderr, "%s: %s\n", status.job_id().c_str(), line.c_str());
  }
  std::fflush(stderr);
}

void ProgressDisplay::finish() {
  if (drawn_) std::fprintf(stderr, "\n");
  drawn_ = false;
  lastWidth_ = 0;
}

}  // namespace lensfarm::cli
