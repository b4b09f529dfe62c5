#include "progress_display.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include <fmt/format.h>

#include "film/convergence.h"
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

ProgressDisplay::ProgressDisplay(bool enabled, bool toTerminal, double watchTarget)
    : enabled_(enabled), terminal_(toTerminal), watchTarget_(watchTarget) {}

std::string convergenceText(const v1::JobProgress& p, double watchTarget) {
  const double estimate = p.estimated_relative_error();
  if (estimate < 0.0) return "err -";
  std::string text = fmt::format("err {:.2f} %", 100.0 * estimate);
  const double target = p.target_error() > 0.0 ? p.target_error() : watchTarget;
  if (target > 0.0) {
    const double eta = p.target_error() > 0.0 ? p.seconds_to_target()
                                              : secondsToTarget(estimate, target, p.elapsed_seconds());
    if (estimate <= target)
      text += fmt::format(" (target {:.2f} % reached)", 100.0 * target);
    else if (!p.stop_reason().empty())  // finished short of it: nothing to project
      text += fmt::format(" (target {:.2f} %)", 100.0 * target);
    else
      text += fmt::format(" (target {:.2f} % in ~{})", 100.0 * target, formatDuration(eta));
  }
  return text;
}

void ProgressDisplay::update(const v1::JobStatus& status) {
  if (!enabled_) return;
  const double t = now();
  const auto& p = status.progress();
  const bool terminal = status.state() == v1::JOB_STATE_DONE || status.state() == v1::JOB_STATE_CANCELLED ||
                        status.state() == v1::JOB_STATE_FAILED;
  if (t - lastDraw_ < (terminal_ ? 0.1 : 2.0) && !terminal) return;
  lastDraw_ = t;
  // The bar shows whichever stopping rule is nearest: samples, the target error (error^2 falls
  // as 1/time, so the fraction of the time needed is (target / error)^2) or the deadline.
  const bool capped = p.samples_per_pixel_total() < kMaxSamplesPerPixel;
  double fraction = capped && p.units_total() ? double(p.units_done()) / double(p.units_total()) : 0.0;
  const double estimate = p.estimated_relative_error();
  if (p.target_error() > 0.0 && estimate > 0.0)
    fraction = std::max(fraction, std::min(1.0, (p.target_error() / estimate) * (p.target_error() / estimate)));
  if (p.time_limit_seconds() > 0.0 && p.elapsed_seconds() + p.remaining_seconds() > 0.0)
    fraction = std::max(fraction, p.elapsed_seconds() / (p.elapsed_seconds() + p.remaining_seconds()));
  if (status.state() == v1::JOB_STATE_DONE) fraction = 1.0;
  const std::string total = capped ? "/" + std::to_string(p.samples_per_pixel_total()) : "";
  const std::string line =
      fmt::format("{} {}{} spp  {}  {:.2f} Mrays/s  {} busy  {} elapsed  {} left", stateName(status.state()),
                  p.samples_per_pixel_done(), total, convergenceText(p, watchTarget_), p.rays_per_second() / 1e6,
                  p.workers_busy(), formatDuration(p.elapsed_seconds()), formatDuration(p.remaining_seconds()));
  if (terminal_) {
    const int width = 30;
    std::string bar(size_t(fraction * width), '=');
    bar.resize(width, ' ');
    std::fprintf(stderr, "\r[%s] %s   ", bar.c_str(), line.c_str());
    drawn_ = true;
  } else {
    std::fprintf(stderr, "%s: %s\n", status.job_id().c_str(), line.c_str());
  }
  std::fflush(stderr);
}

void ProgressDisplay::finish() {
  if (drawn_) std::fprintf(stderr, "\n");
  drawn_ = false;
}

}  // namespace lensfarm::cli
