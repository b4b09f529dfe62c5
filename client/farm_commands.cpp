// The farm commands: submit, status (alias jobs), watch, download, cancel, delete, archive, workers. Each talks to the
// coordinator named by --coordinator or LENSFARM_COORDINATOR.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <string>

#include "client/commands.h"
#include "client/denoise_output.h"
#include "client/exit_codes.h"
#include "client/farm_client.h"
#include "client/farm_connection.h"
#include "client/output_paths.h"
#include "client/override_flags.h"
#include "client/policy_flags.h"
#include "client/progress_display.h"
#include "common/film/image_io.h"
#include "common/scene/frame_range.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "common/util/secret.h"
#include "proto/convert.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

namespace {

// "2026-11-26 01:46:51": a moment in this machine's time zone, to the second.
std::string localTimeText(double unixSeconds) {
  const std::time_t t = std::time_t(unixSeconds);
  std::tm local{};
  char text[32];
  if (!::localtime_r(&t, &local) || !std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", &local)) return "?";
  return text;
}

// The job's scheduling policy, the lines that differ from the default only.
void printPolicy(const v1::JobPolicy& wire) {
  const JobPolicy p = proto::fromProto(wire);
  if (!p.after.empty()) {
    std::string list;
    for (const Dependency& d : p.after) list += (list.empty() ? "" : ", ") + dependencyText(d);
    std::printf("after:      %s (on failure: %s)\n", logText(list).c_str(),
                p.onDependencyFailure == OnDependencyFailure::kWait ? "wait" : "fail");
  }
  if (!p.requireTags.empty()) std::printf("requires:   %s\n", tagsText(p.requireTags).c_str());
  if (!p.preferTags.empty()) std::printf("prefers:    %s\n", tagsText(p.preferTags).c_str());
  if (!p.auditRequireTags.empty()) std::printf("audits on:  %s\n", tagsText(p.auditRequireTags).c_str());
  if (p.maxWorkers) std::printf("max workers: %u\n", *p.maxWorkers);
  if (p.shareWeight != 1.0) std::printf("share:      %g\n", p.shareWeight);
  if (p.maxUnitFailures || p.maxWorkerFailures || p.unitTimeLimitSeconds || p.onFailure == OnFailure::kPause) {
    std::string limits;
    if (p.maxUnitFailures) limits += "a unit on " + std::to_string(*p.maxUnitFailures) + " workers; ";
    if (p.maxWorkerFailures) limits += std::to_string(*p.maxWorkerFailures) + " on one worker; ";
    if (p.unitTimeLimitSeconds) limits += "units within " + std::to_string(*p.unitTimeLimitSeconds) + " s; ";
    std::printf("failures:   %sthen %s\n", limits.c_str(), p.onFailure == OnFailure::kPause ? "pause" : "fail");
  }
}

void printStatus(const v1::JobStatus& s) {
  const auto& p = s.progress();
  std::printf("job:        %s\n", s.job_id().c_str());
  std::printf("state:      %s\n", stateName(s.state()));
  std::printf("scene:      %s (%ux%u)\n", logText(s.scene_name()).c_str(), s.width(), s.height());
  std::printf("priority:   %d\n", s.priority());
  if (!s.owner().empty()) std::printf("owner:      %s\n", logText(s.owner()).c_str());
  if (s.ended_unix_seconds() > 0.0) std::printf("ended:      %s\n", localTimeText(s.ended_unix_seconds()).c_str());
  if (s.archived()) std::printf("archived:   yes (final image kept; sensor and ledger freed)\n");
  if (s.paused()) std::printf("paused:     yes (lensfarm resume %s)\n", s.job_id().c_str());
  if (s.approved()) std::printf("approved:   yes\n");
  printPolicy(s.policy());
  for (const auto& w : s.waiting_for()) std::printf("waits for:  %s\n", logText(w).c_str());
  if (!s.deadline_outlook().empty()) std::printf("outlook:    %s\n", logText(s.deadline_outlook()).c_str());
  if (hasSampleCap(p))
    std::printf("samples:    %llu / %llu per pixel (%llu / %llu units)\n",
                (unsigned long long)p.samples_per_pixel_done(), (unsigned long long)p.samples_per_pixel_total(),
                (unsigned long long)p.units_done(), (unsigned long long)p.units_total());
  else  // running to a target error or a deadline: the internal cap is no total
    std::printf("samples:    %llu per pixel (%llu units; no sample cap)\n",
                (unsigned long long)p.samples_per_pixel_done(), (unsigned long long)p.units_done());
  if (s.tile_size() > 0)
    std::printf("tiles:      %u px, %llu a frame (docs/farm.md \"Tiles and passes\")\n", s.tile_size(),
                (unsigned long long)s.tiles_per_frame());
  if (s.frames_size() > 0) {
    // Per frame: done (#), being rendered (+, with its tiles) or waiting (.).
    int complete = 0;
    std::string line, partial;
    for (const v1::FrameStatus& f : s.frames()) {
      complete += f.complete();
      line += f.complete() ? '#' : f.tiles_done() > 0 ? '+' : '.';
      if (!f.complete() && f.tiles_done() > 0)
        partial += (partial.empty() ? "" : ", ") + std::to_string(f.frame()) + ": " + std::to_string(f.tiles_done()) +
                   "/" + std::to_string(f.tiles_total()) + " tiles";
    }
    std::printf("frames:     %d of %d complete (%lld-%lld)%s%s\n", complete, s.frames_size(),
                (long long)s.frames(0).frame(), (long long)s.frames(s.frames_size() - 1).frame(),
                partial.empty() ? "" : "; rendering ", partial.c_str());
    if (s.frames_size() <= 480) std::printf("            %s\n", line.c_str());
  }
  std::printf("rays:       %llu (%.2f M rays/s)\n", (unsigned long long)p.rays(), p.rays_per_second() / 1e6);
  std::printf("elapsed:    %s\n", formatDuration(p.elapsed_seconds()).c_str());
  std::printf("remaining:  %s\n", timeLeftText(s).c_str());
  std::printf("workers:    %u busy\n", p.workers_busy());
  if (!p.stalled_reason().empty()) std::printf("stalled:    %s\n", logText(p.stalled_reason()).c_str());
  std::printf("light hits: %.2f %%\n", 100.0 * p.light_hit_fraction());
  std::printf("dropped:    %llu samples\n", (unsigned long long)p.dropped_samples());
  std::printf("error:      %s\n", convergenceText(p).c_str());
  if (p.time_limit_seconds() > 0.0)
    std::printf("deadline:   %s after submission\n", formatDuration(p.time_limit_seconds()).c_str());
  if (!p.stop_reason().empty()) std::printf("stopped:    %s\n", logText(p.stop_reason()).c_str());
  if (s.audits_passed() + s.audits_failed() + s.audits_pending() + s.units_rerendered() > 0)
    std::printf("audit:      %llu passed, %llu failed, %llu pending; %llu units rendered again\n",
                (unsigned long long)s.audits_passed(), (unsigned long long)s.audits_failed(),
                (unsigned long long)s.audits_pending(), (unsigned long long)s.units_rerendered());
  if (s.audits_explained() > 0)
    std::printf("            %llu explained by the workers' builds (not wrong)\n",
                (unsigned long long)s.audits_explained());
  for (const auto& e : s.effects()) std::printf("effect:     %s\n", logText(e).c_str());
  if (!s.kernel().empty()) std::printf("kernel:     %s\n", logText(s.kernel()).c_str());
  for (const auto& b : s.builds()) std::printf("build:      %s\n", logText(b).c_str());
  if (!s.events().empty()) std::printf("events:\n");
  for (const auto& e : s.events())
    std::printf("  %s  %s\n", localTimeText(e.unix_seconds()).c_str(), logText(e.text()).c_str());
  if (!s.error().empty()) std::printf("error:      %s\n", logText(s.error()).c_str());
}

}  // namespace

Runner addSubmitCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("submit", "Submit a scene to the farm; prints the job id");
  struct Flags {
    Connection c;
    std::string scene;
    OverrideFlags overrides;
    int priority = 0;
    std::string owner;
    PolicyFlags policy;
    bool paused = false;
  };
  auto f = std::make_shared<Flags>();
  addCoordinatorOption(cmd, f->c);
  if (const char* user = std::getenv("USER")) f->owner = user;
  cmd->add_option("--owner", f->owner, "Who submits the job, shown in status and `jobs --owner` (default: $USER)");
  cmd->add_option("scene", f->scene, "Scene file (JSON), or a model to render as it is (.gltf, .glb, .obj)")
      ->required();
  f->overrides.addTo(cmd);
  cmd->add_option("--priority", f->priority, "Higher runs first (equal priorities share the farm)")
      ->capture_default_str();
  f->policy.addTo(cmd);
  cmd->add_flag("--paused", f->paused, "Submit it paused: nothing is rendered until `lensfarm resume JOB`");
  return [f] {
    const JobPolicy policy = f->policy.toPolicy();
    const RenderOverrides o = f->overrides.toOverrides();
    const LocalJob job =
        makeLocalJob(f->scene, o, f->overrides.camera, f->overrides.frameRange(), f->overrides.allowedFolders());
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      std::printf("%s\n", client.submit(job, f->priority, f->owner, policy, f->paused).job_id().c_str());
      return kOk;
    });
  };
}

Runner addStatusCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("status", "Show one job in detail, or list jobs (also `lensfarm jobs`), filtered");
  cmd->alias("jobs");
  struct Flags : JobArgs {
    std::vector<std::string> states;
    std::string owner, name;
    uint32_t limit = 0;
  };
  auto f = std::make_shared<Flags>();
  addCoordinatorOption(cmd, f->c);
  cmd->add_option("job", f->job, "Job id (default: list the jobs)");
  cmd->add_option("--state", f->states, "List jobs in these states: queued, running, done, cancelled, failed")
      ->delimiter(',')
      ->check(CLI::IsMember({"queued", "running", "done", "cancelled", "failed"}));
  cmd->add_option("--owner", f->owner, "List the jobs of this owner");
  cmd->add_option("--name", f->name, "List jobs whose scene name contains this text");
  cmd->add_option("--limit", f->limit, "List at most this many (0: all)");
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      if (!f->job.empty()) {
        printStatus(client.get(f->job));
        return kOk;
      }
      v1::ListJobsRequest filters;
      for (const std::string& state : f->states) filters.add_state_names(state);
      filters.set_owner(f->owner);
      filters.set_name_contains(f->name);
      filters.set_limit(f->limit);
      const std::vector<v1::JobStatus> jobs = client.list(filters);
      // OWNER comes last (before the archived mark), so scripts that read the columns before it keep working.
      std::printf("%-10s %-10s %8s %-24s %18s %10s  %s\n", "JOB", "STATE", "PRIORITY", "SCENE", "SPP", "ELAPSED",
                  "OWNER");
      for (const auto& s : jobs) {
        const std::string spp = samplesText(s.progress());
        std::printf("%-10s %-10s %8d %-24s %18s %10s  %s%s\n", s.job_id().c_str(), stateName(s.state()), s.priority(),
                    logText(s.scene_name()).c_str(), spp.c_str(),
                    formatDuration(s.progress().elapsed_seconds()).c_str(),
                    s.owner().empty() ? "-" : logText(s.owner()).c_str(),
                    s.archived()               ? " (archived)"
                    : s.paused()               ? " (paused)"
                    : !s.waiting_for().empty() ? " (waiting)"
                                               : "");
      }
      return kOk;
    });
  };
}

Runner addWatchCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("watch", "Follow a job until it ends (exit 0 when done)");
  struct Flags : JobArgs {
    double target = 0.0;
  };
  auto f = std::make_shared<Flags>();
  addJobArgs(cmd, *f);
  cmd->add_option("--target-error", f->target,
                  "Project the time to this relative error (default: the job's own target, if any)")
      ->check(numberIn(1e-6, 0.999));
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      ProgressDisplay display(true, ::isatty(STDERR_FILENO), f->target);
      // A stall (no worker renders the job) is said once on a line of its own, with its reason,
      // and again when the reason changes (its seconds aside) or the job moves on.
      std::string stall;
      const auto withoutDigits = [](std::string text) {
        text.erase(std::remove_if(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }), text.end());
        return text;
      };
      // The job's events (workers lost, rejoining or quarantined; audits), each printed once, as
      // it arrives: the list holds the latest 64, so they are told apart by time and text.
      std::set<std::pair<double, std::string>> told;
      const v1::JobStatus last = client.watch(f->job, [&](const v1::JobStatus& s) {
        for (const v1::JobEvent& e : s.events()) {
          if (!told.emplace(e.unix_seconds(), e.text()).second) continue;
          display.finish();
          std::fprintf(stderr, "%s: %s  %s\n", s.job_id().c_str(), localTimeText(e.unix_seconds()).c_str(),
                       logText(e.text()).c_str());
        }
        const std::string& reason = s.progress().stalled_reason();
        if (withoutDigits(reason) != withoutDigits(stall)) {
          display.finish();
          if (!reason.empty())
            std::fprintf(stderr, "%s: stalled: %s\n", s.job_id().c_str(), logText(reason).c_str());
          else
            std::fprintf(stderr, "%s: rendering again\n", s.job_id().c_str());
          stall = reason;
        }
        display.update(s);
      });
      display.finish();
      std::printf("%s %s: %llu spp, %s%s\n", last.job_id().c_str(), stateName(last.state()),
                  (unsigned long long)last.progress().samples_per_pixel_done(),
                  convergenceText(last.progress(), f->target).c_str(),
                  last.progress().stop_reason().empty() ? "" : ("; " + logText(last.progress().stop_reason())).c_str());
      if (last.state() == v1::JOB_STATE_DONE) return kOk;
      if (!last.error().empty()) std::fprintf(stderr, "lensfarm: job failed: %s\n", logText(last.error()).c_str());
      return kJobNotDone;
    });
  };
}

Runner addDownloadCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("download", "Download a job's image as it is now (.exr linear, .png exposed)");
  struct Flags : JobArgs {
    std::vector<std::string> outputs;
    std::optional<double> ev;
    std::optional<int64_t> frame;
    bool denoise = false;
  };
  auto f = std::make_shared<Flags>();
  addJobArgs(cmd, *f);
  cmd->add_flag("--denoise", f->denoise,
                "Denoise the image here (docs/aovs.md), guided by the job's albedo, normal and variance AOVs; the "
                "EXR keeps the raw image as its layer 'noisy', a PNG shows the denoised one (auto exposure, --ev)");
  cmd->add_option("-o,--output", f->outputs,
                  "Output file(s): .exr or .png; for an animation a pattern (out/shot_####.exr) gets every "
                  "complete frame")
      ->required();
  cmd->add_option("--frame", f->frame, "Only this frame of an animation (a name without #### is then allowed)");
  cmd->add_option("--ev", f->ev, "Exposure compensation for PNG (default: the job's)")
      ->check(numberIn(-kMaxExposureEv, kMaxExposureEv, "stops"));
  return [f] {
    std::vector<std::pair<std::string, v1::ImageFormat>> targets;
    for (const auto& o : f->outputs) {
      const fs::path path = checkedOutput(o, {".exr", ".png"});
      targets.emplace_back(o, path.extension() == ".exr" ? v1::IMAGE_FORMAT_EXR : v1::IMAGE_FORMAT_PNG);
    }
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      const v1::JobStatus status = client.get(f->job);
      // One frame's files: as the coordinator serves them, or with --denoise from its EXR,
      // denoised here (the guide check comes before any file is written).
      const auto writeFrame = [&](std::optional<int64_t> frame,
                                  const std::function<std::string(const std::string&)>& name) {
        if (!f->denoise) {
          for (const auto& [path, format] : targets) {
            const std::string file = name(path);
            client.downloadTo(f->job, format, f->ev, frame, file);
            std::printf("wrote %s\n", file.c_str());
          }
          return;
        }
        ImageMetadata metadata;
        Image image = decodeExr(client.download(f->job, v1::IMAGE_FORMAT_EXR, f->ev, frame), &metadata);
        requireDenoiseGuides(image, f->job + (frame ? " frame " + std::to_string(*frame) : std::string()));
        denoiseForOutput(image, metadata);
        ExposureSettings exposure;
        exposure.ev = f->ev.value_or(0.0);
        for (const auto& [path, format] : targets) {
          const std::string file = name(path);
          writeImageFile(file, image, metadata, exposure);
          std::printf("wrote %s\n", file.c_str());
        }
      };
      if (status.frames_size() == 0 || f->frame) {
        writeFrame(f->frame, [&](const std::string& path) {
          return f->frame && hasFramePattern(path) ? framePath(path, *f->frame) : path;
        });
        return kOk;
      }
      // An animation: every complete frame, each to the pattern's name for it.
      for (const auto& [path, format] : targets) checkFramePattern(path, "-o");
      int written = 0;
      for (const v1::FrameStatus& frame : status.frames()) {
        if (!frame.complete()) continue;
        writeFrame(frame.frame(), [&](const std::string& path) { return framePath(path, frame.frame()); });
        ++written;
      }
      if (written < status.frames_size())
        std::printf("%d of %d frames complete; run again for the others\n", written, status.frames_size());
      return kOk;
    });
  };
}

Runner addSnapshotCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("snapshot", "Save a small PNG preview of a job's image as it is now");
  struct Flags : JobArgs {
    std::string output;
    uint32_t maxSize = 512;
    std::optional<double> ev;
  };
  auto f = std::make_shared<Flags>();
  addJobArgs(cmd, *f);
  cmd->add_option("-o,--output", f->output, "Output PNG")->required();
  cmd->add_option("--max-size", f->maxSize, "Longer side of the preview, pixels")
      ->check(CLI::Range(1u, 1024u))
      ->capture_default_str();
  cmd->add_option("--ev", f->ev, "Exposure compensation (default: the job's)")
      ->check(numberIn(-kMaxExposureEv, kMaxExposureEv, "stops"));
  return [f] {
    const fs::path path = checkedOutput(f->output, {".png"});
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      const v1::Snapshot s = client.snapshot(f->job, f->maxSize, f->ev);
      writeBytesAtomically(path, s.png());
      std::printf("wrote %s (%ux%u, %llu spp, %s)\n", path.c_str(), s.width(), s.height(),
                  (unsigned long long)s.status().progress().samples_per_pixel_done(), stateName(s.status().state()));
      return kOk;
    });
  };
}

Runner addCancelCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("cancel", "Cancel a job (what was accumulated stays downloadable)");
  auto f = std::make_shared<JobArgs>();
  addJobArgs(cmd, *f);
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      const v1::JobStatus s = client.cancel(f->job);
      std::printf("%s %s\n", s.job_id().c_str(), stateName(s.state()));
      return kOk;
    });
  };
}

Runner addDeleteCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("delete",
                                 "Delete jobs for good: their images, ledger and files (refuses a running "
                                 "job unless --force)");
  struct Flags {
    Connection c;
    std::vector<std::string> jobs;
    bool force = false;
  };
  auto f = std::make_shared<Flags>();
  addCoordinatorOption(cmd, f->c);
  cmd->add_option("job", f->jobs, "Job id(s)")->required();
  cmd->add_flag("--force", f->force, "Cancel a queued or running job first instead of refusing");
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      for (const std::string& job : f->jobs) {  // stops at the first refused
        client.deleteJob(job, f->force);
        std::printf("%s deleted\n", job.c_str());
      }
      return kOk;
    });
  };
}

Runner addArchiveCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("archive", "Archive ended jobs: keep the final image, free the sensor and ledger");
  struct Flags {
    Connection c;
    std::vector<std::string> jobs;
  };
  auto f = std::make_shared<Flags>();
  addCoordinatorOption(cmd, f->c);
  cmd->add_option("job", f->jobs, "Job id(s)")->required();
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      for (const std::string& job : f->jobs) {
        const v1::JobStatus s = client.archive(job);
        std::printf("%s %s, archived\n", s.job_id().c_str(), stateName(s.state()));
      }
      return kOk;
    });
  };
}

Runner addWorkersCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("workers", "List the workers the coordinator knows");
  auto c = std::make_shared<Connection>();
  addCoordinatorOption(cmd, *c);
  return [c] {
    return guardedCall([&] {
      FarmClient client(c->coordinator, c->resolved());
      const std::vector<v1::WorkerStatus> workers = client.workers();
      // STATE comes last, so scripts that read the columns before it keep working.
      std::printf("%-18s %-28s %7s %-10s %8s %10s  %s\n", "WORKER", "NAME", "THREADS", "JOB", "UNITS", "SEEN", "STATE");
      for (const auto& w : workers) {
        // lost, left and stale say since when and why.
        char since[32];
        std::snprintf(since, sizeof since, "%.1f s", w.seconds_in_state());
        std::string state = w.state().empty() ? "-" : w.state();
        if (w.state() == "idle" && !w.state_reason().empty()) state += ": " + w.state_reason();
        if (w.state() == "lost" || w.state() == "left")
          state += std::string(" ") + since + " ago" + (w.state_reason().empty() ? "" : ": " + w.state_reason());
        else if (w.state() == "stale")
          state += std::string(", no heartbeat for ") + since;
        // A quarantined worker is leased nothing more (docs/farm.md "Audit"): said first.
        if (w.quarantined())
          state = "quarantined" + (w.quarantine_reason().empty() ? "" : ": " + w.quarantine_reason()) + "; " + state;
        if (w.failures() > 0) state += "; " + std::to_string(w.failures()) + " failed unit(s)";
        if (w.audits_passed() > 0)
          state += "; " + std::to_string(w.audits_passed()) + " of its units confirmed by audit";
        if (w.audits_rendered() > 0) state += "; audited " + std::to_string(w.audits_rendered()) + " of other workers'";
        for (const std::string& job : w.blocklisted_jobs()) state += "; blocklisted for " + job;
        if (!w.credential().empty())
          state += "; credential " + w.credential() +
                   (w.registrations() > 1 ? " (registered " + std::to_string(w.registrations()) + " times)" : "");
        if (w.kernels_size() > 0) {  // docs/farm.md "Mixed machines"
          std::string kernels;
          for (const std::string& k : w.kernels()) kernels += (kernels.empty() ? "" : " ") + k;
          state += "; kernels " + kernels;
        }
        if (w.tags_size() > 0) {  // docs/farm.md "Scheduling"
          std::string tags;
          for (const std::string& t : w.tags()) tags += (tags.empty() ? "" : ",") + t;
          state += "; tags " + tags;
        }
        std::printf("%-18s %-28s %7u %-10s %8llu %9.1fs  %s\n", logText(w.worker_id()).c_str(),
                    logText(w.name()).c_str(), w.threads(),
                    w.current_job_id().empty() ? "-" : w.current_job_id().c_str(), (unsigned long long)w.units_done(),
                    w.seconds_since_heartbeat(), logText(state).c_str());
      }
      return kOk;
    });
  };
}

}  // namespace lensfarm::cli
