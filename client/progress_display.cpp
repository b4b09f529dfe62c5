#include "progress_display.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "scene/scene_loader.h"

namespace lensfarm::cli {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
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

ProgressDisplay::ProgressDisplay(bool enabled, bool toTerminal, double timeLimitSeconds)
    : enabled_(enabled), terminal_(toTerminal), timeLimit_(timeLimitSeconds) {}

void ProgressDisplay::update(const v1::JobStatus& status) {
  if (!enabled_) return;
  const double t = now();
  const auto& p = status.progress();
  const bool terminal = status.state() == v1::JOB_STATE_DONE || status.state() == v1::JOB_STATE_CANCELLED ||
                        status.state() == v1::JOB_STATE_FAILED;
  if (t - lastDraw_ < (terminal_ ? 0.1 : 2.0) && !terminal) return;
  lastDraw_ = t;
  const bool untilTime = timeLimit_ > 0 && p.samples_per_pixel_total() >= kMaxSamplesPerPixel;
  double fraction = p.units_total() ? double(p.units_done()) / double(p.units_total()) : 0.0;
  double remaining = p.remaining_seconds();
  if (timeLimit_ > 0) {
    const double byTime = std::min(1.0, p.elapsed_seconds() / timeLimit_);
    if (untilTime || byTime > fraction) {
      fraction = byTime;
      remaining = std::max(0.0, timeLimit_ - p.elapsed_seconds());
    }
  }
  const std::string total = untilTime ? "" : "/" + std::to_string(p.samples_per_pixel_total());
  char line[256];
  std::snprintf(line, sizeof line, "%s %llu%s spp  %.2f Mrays/s  %u busy  %s elapsed  %s left", stateName(status.state()),
                (unsigned long long)p.samples_per_pixel_done(), total.c_str(), p.rays_per_second() / 1e6,
                p.workers_busy(), formatDuration(p.elapsed_seconds()).c_str(), formatDuration(remaining).c_str());
  if (terminal_) {
    const int width = 30;
    std::string bar(size_t(fraction * width), '=');
    bar.resize(width, ' ');
    std::fprintf(stderr, "\r[%s] %s   ", bar.c_str(), line);
    drawn_ = true;
  } else {
    std::fprintf(stderr, "%s: %s\n", status.job_id().c_str(), line);
  }
  std::fflush(stderr);
}

void ProgressDisplay::finish() {
  if (drawn_) std::fprintf(stderr, "\n");
  drawn_ = false;
}

}  // namespace lensfarm::cli
