// `lensfarm render SCENE [-o out.exr] [-o out.png] [--spp N | --time S] ...`: renders on this
// machine's cores through an embedded coordinator and worker (the farm's own classes), writing
// snapshots while it traces and the final image at the end or on Ctrl-C. An output is only ever
// written with at least one whole unit in it: never an image of no samples.
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <tbb/parallel_for_each.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "client/commands.h"
#include "client/denoise_output.h"
#include "client/exit_codes.h"
#include "client/in_process_link.h"
#include "client/job_spec.h"
#include "client/output_paths.h"
#include "client/override_flags.h"
#include "client/progress_display.h"
#include "common/farm/job_layout.h"
#include "common/farm/memory_estimate.h"
#include "common/film/image_io.h"
#include "common/render/ray_caster.h"
#include "common/scene/effects.h"
#include "common/scene/frame_range.h"
#include "common/scene/render_overrides.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/service.h"
#include "worker/worker_loop.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> gInterrupted{false};

extern "C" void onSigint(int) {
  gInterrupted.store(true);
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C stops at once
}

// Phase timings of the whole process (docs/performance.md, "Everything around the render"), at
// debug level on a logger of their own, so the render's own levels (warn while tracing) do not
// hide them: LENSFARM_TIMINGS=1 prints one line per phase on stderr, each with the process's minor
// page faults in the phase (a first write to a 4 KiB page: what frame-sized buffers cost where
// huge pages are not given, util/large_pages.h) and the wall-clock time it ended (Unix seconds,
// for bench/whole_process.sh to add process start and exit).
class PhaseTimer {
 public:
  using Clock = std::chrono::steady_clock;
  // A sink of its own: a pattern set on a shared sink would change the main logger's lines too.
  PhaseTimer() : logger_("lensfarm.timings", std::make_shared<spdlog::sinks::stderr_sink_mt>()) {
    logger_.set_pattern("%v");
    logger_.set_level(std::getenv("LENSFARM_TIMINGS") ? spdlog::level::debug : spdlog::level::off);
    mark("main");  // when the command started: process start-up is what came before
  }
  // Ends the phase `name` at now; the next one starts.
  void mark(const char* name) {
    std::lock_guard lock(mutex_);
    last_ = log(name, last_);
  }
  // Logs the time from the start of the current phase to now without ending it: for work done
  // side by side (the outputs), each part's own time, the phase's mark its whole.
  void lap(const char* name) {
    std::lock_guard lock(mutex_);
    log(name, last_);
  }

 private:
  Clock::time_point log(const char* name, Clock::time_point since) {
    const auto now = Clock::now();
    const double unixSeconds =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    rusage usage{};
    ::getrusage(RUSAGE_SELF, &usage);
    logger_.debug("timing {:<14} {:9.2f} ms {:7} faults  (ends at {:.6f})", name,
                  std::chrono::duration<double, std::milli>(now - since).count(), usage.ru_minflt - faults_,
                  unixSeconds);
    faults_ = usage.ru_minflt;
    return now;
  }
  std::mutex mutex_;
  spdlog::logger logger_;
  Clock::time_point last_ = Clock::now();
  long faults_ = 0;  // minor faults when the last line was logged
};

struct RenderFlags {
  std::string scene;
  std::vector<std::string> outputs;
  OverrideFlags overrides;
  std::optional<double> timeLimit;
  std::optional<unsigned> threads;
  double snapshotEvery = 0.0;
  double progressEvery = 5.0;  // seconds between plain progress lines (stderr not a terminal)
  std::string exrCompression = "none";
  bool quiet = false;
  bool denoise = false;  // --denoise: outputs denoised, the raw beauty kept as layer "noisy"

  ExrCompression compression() const { return exrCompression == "zip" ? ExrCompression::kZip : ExrCompression::kNone; }
};

RenderOverrides toOverrides(const RenderFlags& f) {
  RenderOverrides o = f.overrides.toOverrides();
  if (f.timeLimit) {  // --time S is --deadline S
    o.timeLimitSeconds = *f.timeLimit;
    if (!o.samplesPerPixel) o.samplesPerPixel = kMaxSamplesPerPixel;  // --time alone: until time is up
  }
  return o;
}

// Every output of one image, at once: the EXR and the PNG are independent (each file atomic on
// its own), so on two cores the PNG's exposure and deflate run beside the EXR's write.
// `written(path)` is called as each is done (from the thread that wrote it).
template <class OnWritten>
void writeOutputs(const std::vector<fs::path>& outputs, const JobImage& image, ExrCompression compression,
                  const OnWritten& written) {
  tbb::parallel_for_each(outputs.begin(), outputs.end(), [&](const fs::path& path) {
    writeImageFile(path, image.image, image.metadata, image.exposure, compression);
    written(path);
  });
}

void writeOutputs(const std::vector<fs::path>& outputs, const JobImage& image, ExrCompression compression) {
  writeOutputs(outputs, image, compression, [](const fs::path&) {});
}

// The image as the outputs hold it: with --denoise, denoised (client/denoise_output.h).
JobImage forOutput(JobImage image, bool denoise) {
  if (denoise) denoiseForOutput(image.image, image.metadata);
  return image;
}

// An animation's frames that completed since the last call, each to every output pattern.
void writeCompleteFrames(const Coordinator& coordinator, const JobInfo& info, const std::vector<fs::path>& patterns,
                         ExrCompression compression, bool denoise, std::set<int64_t>& written) {
  for (const JobInfo::Frame& frame : info.frames) {
    if (!frame.complete() || written.count(frame.number)) continue;
    std::vector<fs::path> paths;
    for (const auto& pattern : patterns) paths.push_back(framePath(pattern.string(), frame.number));
    writeOutputs(paths, forOutput(coordinator.image(info.id, frame.number), denoise), compression);
    written.insert(frame.number);
  }
}

// The outputs asked for (-o), or the default ones named after the scene; an animation's get
// "_####" before their extension.
std::vector<std::string> outputPatterns(const RenderFlags& flags, const std::optional<FrameRange>& frames) {
  std::vector<std::string> patterns = flags.outputs;
  if (patterns.empty())
    for (const fs::path o : defaultOutputs(flags.scene))
      patterns.push_back(frames ? (o.parent_path() / (o.stem().string() + "_####" + o.extension().string())).string()
                                : o.string());
  return patterns;
}

// Each output checked (a writable .exr or .png; an animation's with a frame-number pattern),
// InputError naming -o.
std::vector<fs::path> checkedOutputs(const std::vector<std::string>& patterns,
                                     const std::optional<FrameRange>& frames) {
  std::vector<fs::path> outputs;
  for (const auto& o : patterns) {
    if (frames && frames->count() > 1) checkFramePattern(o, "-o");
    outputs.push_back(checkedOutput(o, {".exr", ".png"}));
  }
  return outputs;
}

// What is about to be rendered, and how, said before the first ray: the scene's size, the sample
// budget and settings, the notes of its loading, and what the render leaves out of what the
// scene asks for (scene/effects.h).
void logRenderPlan(const RenderFlags& flags, const Scene& scene, unsigned threads, bool animation) {
  const RenderSettings& settings = scene.render;
  std::string triangles = std::to_string(storedTriangles(scene)) + " triangles";
  if (!scene.instances.empty()) triangles += fmt::format(" (shared meshes drawn {} times)", scene.instances.size());
  std::string budget = settings.samplesPerPixel >= kMaxSamplesPerPixel
                           ? std::string("no sample cap")
                           : std::to_string(settings.samplesPerPixel) + " spp";
  if (settings.targetError > 0.0) budget += fmt::format(", to {:.3g} % relative error", 100.0 * settings.targetError);
  if (settings.timeLimitSeconds > 0.0) budget += fmt::format(", for at most {} s", settings.timeLimitSeconds);
  spdlog::info("{}: {}, {}x{} px, {} in units of {} spp, B = {}, {}, {} sampler on {} threads", flags.scene, triangles,
               settings.width, settings.height, budget, unitSize(settings), settings.maxBounces,
               integratorName(settings.integrator), samplerName(settings.sampler), threads);
  if (const std::string a = JobLayout::of(settings, std::nullopt).adaptiveSummary(); !a.empty() && !animation)
    spdlog::info("{}: {}", flags.scene, a);
  for (const std::string& note : scene.notes) spdlog::info("{}: {}", flags.scene, note);
  if (const double framed = scene.cameraFramedAspect, image = double(settings.width) / settings.height;
      framed > 0.0 && std::abs(framed / image - 1.0) > 0.01)
    spdlog::info(
        "{}: the camera was framed for aspect ratio {:.4g}, rendered at {:.4g} ({}x{}): its vertical angle of "
        "view is kept, so the sides show {}",
        flags.scene, framed, image, settings.width, settings.height, image > framed ? "more" : "less");
  if (scene.skippedDegenerateTriangles)
    spdlog::warn("{}: skipped {} zero-area triangles", flags.scene, scene.skippedDegenerateTriangles);
  // What the render leaves out of what the scene asks for is said before the first ray, not only
  // in the summary at the end (scene/effects.h).
  for (const std::string& w : analyzeEffects(scene, scene.camera()).warnings()) spdlog::warn("{}: {}", flags.scene, w);
}

// The summary on stdout: samples, paths, rays, time, the error estimate, why it stopped, the
// effects simulated and the files written.
void printSummary(const JobInfo& info, const JobImage& image, bool interrupted, const std::optional<FrameRange>& frames,
                  const std::set<int64_t>& written, const std::vector<std::string>& patterns,
                  const std::vector<fs::path>& outputs) {
  const double seconds = std::max(info.elapsedSeconds, 1e-9);
  std::printf("samples per pixel: %llu%s\n", (unsigned long long)image.metadata.samplesPerPixel,
              interrupted ? " (interrupted)" : "");
  std::printf("paths:             %llu (%.3f M paths/s)\n", (unsigned long long)info.stats.paths,
              double(info.stats.paths) / seconds / 1e6);
  std::printf("rays:              %llu (%.3f M rays/s)\n", (unsigned long long)info.stats.rays,
              double(info.stats.rays) / seconds / 1e6);
  std::printf("light-hit fraction: %.2f %%\n", 100.0 * info.lightHitFraction());
  std::printf("dropped samples:   %llu\n", (unsigned long long)info.stats.dropped);
  std::printf("time:              %.2f s\n", info.elapsedSeconds);
  if (info.estimatedRelativeError >= 0.0)
    std::printf("estimated error:   %.3f %% relative RMSE (film/convergence.h)\n", 100.0 * info.estimatedRelativeError);
  else if (info.unitsDone > 0)
    std::printf("estimated error:   unknown\n");  // fewer than two units, or a black image
  if (!info.stopReason.empty()) std::printf("stopped:           %s\n", info.stopReason.c_str());
  for (const auto& e : info.effects) std::printf("effect:            %s\n", e.c_str());
  if (frames)
    std::printf("frames:            %zu of %llu written (%s), %s\n", written.size(),
                (unsigned long long)frames->count(), formatFrameRange(*frames).c_str(), patterns.front().c_str());
  else
    for (const auto& o : outputs) std::printf("wrote %s\n", o.c_str());
}

// Follows the job until it ends, writing snapshots (--snapshot-every) and an animation's frames
// as they complete; Ctrl-C cancels it, keeping the units already added. Returns whether it was
// interrupted.
bool followJob(Coordinator& coordinator, WorkerLoop& worker, JobInfo& info, const RenderFlags& flags,
               const std::optional<FrameRange>& frames, const std::vector<fs::path>& outputs,
               std::set<int64_t>& written, ProgressDisplay& display) {
  double lastSnapshot = 0.0;
  for (;;) {
    info = coordinator.waitForChange(info.id, info.version, 0.1);
    display.update(toProto(info));
    if (isTerminal(info.state)) break;
    // The coordinator applies the time limit and target error itself (whole units); Ctrl-C
    // cancels, keeping the units already added.
    if (gInterrupted) {
      coordinator.cancel(info.id);  // whole units only: the one in flight is dropped
      worker.stopNow();
      return true;
    }
    if (frames) writeCompleteFrames(coordinator, info, outputs, flags.compression(), flags.denoise, written);
    if (!frames && flags.snapshotEvery > 0 && info.unitsDone > 0 &&
        info.elapsedSeconds - lastSnapshot >= flags.snapshotEvery) {
      writeOutputs(outputs, forOutput(coordinator.image(info.id), flags.denoise), flags.compression());
      lastSnapshot = info.elapsedSeconds;
    }
  }
  return false;
}

// The coordinator of `lensfarm render`: the farm in one process (docs/architecture.md, "The farm
// in one process").
std::unique_ptr<Coordinator> embeddedCoordinator() {
  Coordinator::Options options;
  options.maxJobMemoryBytes = std::numeric_limits<uint64_t>::max();  // runRender checks the whole process
  options.memoryBudgetBytes = std::numeric_limits<uint64_t>::max();
  options.leaseTimeoutSeconds = 3600.0;  // the worker cannot vanish: it is this process
  options.heartbeatIntervalSeconds = 0.25;
  options.auditFraction = 0.0;  // one worker: nobody to compare with (docs/farm.md "Audit")
  return std::make_unique<Coordinator>(options);
}

// The farm in one process (docs/architecture.md, "The farm in one process"): an embedded
// coordinator and one worker with all threads, wired by direct calls: the same scheduling,
// upload and accumulation as over gRPC. Owned through pointers so that they can be freed beside
// the writing of the outputs (releaseInBackground). Whatever throws while the worker runs, its
// thread is stopped and joined first (the destructor), so the error is reported, not a
// std::terminate.
class LocalFarm {
 public:
  explicit LocalFarm(const LocalJob& local) : coordinator_(embeddedCoordinator()) {
    for (const auto& [sha, bytes] : local.assetBytes) coordinator_->putAsset(sha, bytes);
  }
  ~LocalFarm() {
    if (!thread_.joinable()) return;
    worker_->stopNow();
    thread_.join();
  }
  Coordinator& coordinator() { return *coordinator_; }
  WorkerLoop& worker() { return *worker_; }

  // The worker, on a thread of its own with `threads` render threads.
  void startWorker(unsigned threads) {
    link_ = std::make_unique<InProcessLink>(*coordinator_);
    WorkerOptions options;
    options.name = "local";
    options.threads = threads;
    // Idle only between a job's rounds and at its end, where stopWorker waits out the poll in
    // flight: a short one keeps that wait off the command's time (a poll is a function call here).
    options.leaseWaitSeconds = 0.05;
    worker_ = std::make_unique<WorkerLoop>(*link_, options);
    thread_ = std::thread([this] {
      try {
        worker_->run();
      } catch (...) {
        error_ = std::current_exception();
      }
    });
  }
  // Stops the worker after its unit in flight and joins its thread.
  void stopWorker() {
    worker_->stop();
    thread_.join();
  }
  // What the worker's thread threw, if anything (after stopWorker).
  void rethrowWorkerError() const {
    if (error_) std::rethrow_exception(error_);
  }
  // Frees the worker, link and coordinator, in the order the stack would, on a thread the caller
  // joins (after stopWorker).
  std::thread releaseInBackground() {
    return std::thread([this] {
      worker_.reset();
      link_.reset();
      coordinator_.reset();
    });
  }

 private:
  std::unique_ptr<Coordinator> coordinator_;
  std::unique_ptr<InProcessLink> link_;
  std::unique_ptr<WorkerLoop> worker_;
  std::thread thread_;
  std::exception_ptr error_;
};

// A still's image (denoised if asked), written to every output. Nothing here needs the farm again
// (the worker has stopped; `info` is a copy): its frame-sized buffers (150 MB at 1080p) and
// scenes are freed on a thread of their own while the outputs are written, joined before this
// returns, a throw included.
JobImage writeStill(LocalFarm& farm, const JobInfo& info, const RenderFlags& flags,
                    const std::vector<fs::path>& outputs, PhaseTimer& timer) {
  JobImage image = farm.coordinator().image(info.id);
  timer.mark("image");
  if (flags.denoise) {
    image = forOutput(std::move(image), true);
    timer.mark("denoise");
  }
  std::thread freeing = farm.releaseInBackground();
  struct JoinFreeing {
    std::thread& thread;
    ~JoinFreeing() { thread.join(); }
  } joinFreeing{freeing};
  writeOutputs(outputs, image, flags.compression(),
               [&](const fs::path& path) { timer.lap(path.extension() == ".exr" ? "write_exr" : "write_png"); });
  timer.mark("write_outputs");
  return image;
}

int runRender(const RenderFlags& flags, PhaseTimer& timer) {
  const std::optional<FrameRange> frames = flags.overrides.frameRange();
  LocalJob local =
      makeLocalJob(flags.scene, toOverrides(flags), flags.overrides.camera, frames, flags.overrides.allowedFolders());
  if (flags.denoise) {  // the guides' AOVs join the scene's (and --aov's), for every process of the job
    local.scene.render.aovs.bits |= denoiseGuideAovs().bits;
    local.spec.overrides.aovs = local.scene.render.aovs;
  }
  timer.mark("scene_load");
  const Scene& scene = local.scene;
  const RenderSettings& settings = scene.render;

  // Refuse bad outputs before tracing a single ray. An animation's are patterns: out/shot_####.exr.
  const std::vector<std::string> patterns = outputPatterns(flags, frames);
  const std::vector<fs::path> outputs = checkedOutputs(patterns, frames);

  // Refuse what this machine cannot hold before allocating anything frame-sized.
  refuseLocalRenderOverBudget(settings, storedTriangles(scene),
                              toOverrides(flags).width ? "--resolution" : flags.scene + ": render.resolution",
                              sceneDataBytes(scene));

  LocalFarm farm(local);
  Coordinator& coordinator = farm.coordinator();
  spdlog::set_level(spdlog::level::warn);
  JobInfo info = coordinator.submit(local.spec, 0);
  spdlog::set_level(spdlog::level::info);
  timer.mark("submit");
  // From here Ctrl-C stops the render cleanly (the log line below says it has begun).
  gInterrupted = false;
  std::signal(SIGINT, onSigint);
  const unsigned threads = flags.threads.value_or(std::max(1u, std::thread::hardware_concurrency()));
  logRenderPlan(flags, scene, threads, frames.has_value());

  // The embedded coordinator and worker log only what goes wrong; the summary below says the rest.
  spdlog::set_level(spdlog::level::warn);
  farm.startWorker(threads);
  ProgressDisplay display(!flags.quiet, ::isatty(STDERR_FILENO), 0.0, flags.progressEvery);
  std::set<int64_t> written;  // an animation's frames written so far
  const bool interrupted = followJob(coordinator, farm.worker(), info, flags, frames, outputs, written, display);
  std::signal(SIGINT, SIG_DFL);
  timer.mark("render_wait");
  farm.stopWorker();
  timer.mark("worker_stop");
  // The worker has stopped: no upload is in flight, so the status and the image agree.
  info = coordinator.job(info.id);
  if (interrupted) display.update(toProto(info));  // the last progress line: cancelled
  display.finish();
  farm.rethrowWorkerError();
  if (info.state == JobState::kFailed) throw std::runtime_error(info.error);

  // Ctrl-C before the first unit: there is no image, so every output is left as it was.
  if (interrupted && info.unitsDone == 0) {
    std::fprintf(stderr,
                 "lensfarm: interrupted before the first unit was done: nothing was rendered (no samples); "
                 "no file was written\n");
    return kInterrupted;
  }
  JobImage image;
  if (frames) {
    writeCompleteFrames(coordinator, info, outputs, flags.compression(), flags.denoise, written);
    image.metadata.samplesPerPixel = info.samplesPerPixelDone;
  } else {
    image = writeStill(farm, info, flags, outputs, timer);
  }
  printSummary(info, image, interrupted, frames, written, patterns, outputs);
  return interrupted ? kInterrupted : kOk;
}

}  // namespace

Runner addRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a scene on this machine's cores");
  cmd->footer(kEmbreeConfigHelp);
  auto f = std::make_shared<RenderFlags>();
  cmd->add_option("scene", f->scene, "Scene file (JSON), or a model to render as it is (.gltf, .glb, .obj)")
      ->required();
  cmd->add_option("-o,--output", f->outputs,
                  "Output image (.exr: linear radiance; .png: exposed preview); repeatable "
                  "(default: SCENE.exr and SCENE.png here, named after the scene file)");
  f->overrides.addTo(cmd);
  cmd->add_option("--time", f->timeLimit,
                  "Render for this many seconds, in whole units (with --spp: whichever comes first); "
                  "the same as --deadline in seconds")
      ->check(positiveNumber("seconds"))
      ->check(numberIn(0.0, 1e9, "seconds"));
  cmd->add_option("--threads", f->threads, "Threads (default: all cores)")->check(wholeNumberIn(1, 4096));
  cmd->add_option("--snapshot-every", f->snapshotEvery,
                  "Write the outputs every S seconds while rendering, once a unit is done (0: never)")
      ->check(nonNegativeNumber("seconds"));
  cmd->add_option("--progress-every", f->progressEvery,
                  "Seconds between progress lines when stderr is not a terminal (logs, CI, batch jobs); default 5")
      ->check(positiveNumber("seconds"));
  cmd->add_option("--exr-compression", f->exrCompression,
                  "none (default: fastest; a 1080p EXR is 25 MB) or zip (smaller, about a second more at 1080p); "
                  "both lossless")
      ->check(CLI::IsMember({"none", "zip"}));
  cmd->add_flag("-q,--quiet", f->quiet, "No progress bar or progress lines");
  cmd->add_flag("--denoise", f->denoise,
                "Write the image denoised (docs/aovs.md): renders the albedo, normal and variance AOVs it needs; "
                "the EXR keeps the raw image as its layer 'noisy'");
  return [f] {
    PhaseTimer timer;
    const int code = runRender(*f, timer);
    timer.mark("teardown");  // the coordinator, worker and scenes freed
    return code;
  };
}

}  // namespace lensfarm::cli
