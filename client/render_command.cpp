// `lensfarm render SCENE -o out.exr [-o out.png] [--spp N | --time S] ...`: renders locally on
// all cores, writing snapshots while it traces and the final image at the end or on Ctrl-C.
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <thread>

#include "commands.h"
#include "exit_codes.h"
#include "film/image_io.h"
#include "render/progressive_render.h"
#include "scene/render_overrides.h"
#include "scene/scene_loader.h"
#include "util/error.h"
#include "util/version.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> gInterrupted{false};

extern "C" void onSigint(int) {
  gInterrupted.store(true);
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C stops at once
}

struct RenderFlags {
  std::string scene;
  std::vector<std::string> outputs;
  std::optional<uint64_t> spp;
  std::optional<double> timeLimit;
  std::optional<unsigned> threads;
  std::optional<std::string> resolution;
  std::optional<int> maxBounces;
  std::optional<uint64_t> seed;
  std::optional<std::string> integrator;
  std::optional<double> ev;
  double snapshotEvery = 0.0;
  bool quiet = false;
};

void applyFlags(const RenderFlags& f, RenderSettings& s) {
  RenderOverrides o;
  if (f.resolution) parseResolution(*f.resolution, o);
  o.samplesPerPixel = f.spp;
  if (!f.spp && f.timeLimit) o.samplesPerPixel = kMaxSamplesPerPixel;  // --time alone: until time is up
  o.maxBounces = f.maxBounces;
  o.seed = f.seed;
  if (f.integrator) o.integrator = *f.integrator == "naive" ? IntegratorKind::kNaive : IntegratorKind::kNeeMis;
  o.ev = f.ev;
  applyOverrides(o, s, "command line");
}

std::string clock(double seconds) {
  const long s = long(seconds + 0.5);
  char buf[32];
  if (s >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  else std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

// One line, redrawn in place, when stderr is a terminal.
class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : enabled_(enabled && ::isatty(STDERR_FILENO)) {}
  void update(const RenderProgress& p) {
    if (!enabled_ || p.elapsedSeconds - lastDraw_ < 0.1) return;
    lastDraw_ = p.elapsedSeconds;
    const int width = 30;
    const int filled = int(p.fractionDone() * width);
    std::string bar(size_t(filled), '=');
    bar.resize(width, ' ');
    std::string target = p.timeLimitSeconds > 0 && p.samplesPerPixelTarget == kMaxSamplesPerPixel
                             ? "" : "/" + std::to_string(p.samplesPerPixelTarget);
    std::fprintf(stderr, "\r[%s] %llu%s spp  %.2f Mrays/s  %s elapsed  %s left   ", bar.c_str(),
                 (unsigned long long)p.samplesPerPixelDone, target.c_str(), p.raysPerSecond() / 1e6,
                 clock(p.elapsedSeconds).c_str(), clock(p.remainingSeconds()).c_str());
    std::fflush(stderr);
    drawn_ = true;
  }
  void finish() {
    if (drawn_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  bool drawn_ = false;
  double lastDraw_ = -1.0;
};

ImageMetadata metadataFor(const Scene& scene, const RenderProgress& p) {
  ImageMetadata m;
  m.samplesPerPixel = p.samplesPerPixelDone;
  m.totalSamples = p.stats.paths;
  m.renderSeconds = p.elapsedSeconds;
  m.sceneHash = scene.hash;
  m.rendererVersion = kRendererVersion;
  m.extra["integrator"] = integratorName(scene.render.integrator);
  m.extra["maxBounces"] = std::to_string(scene.render.maxBounces);
  m.extra["seed"] = std::to_string(scene.render.seed);
  m.extra["rays"] = std::to_string(p.stats.rays);
  m.extra["droppedSamples"] = std::to_string(p.stats.dropped);
  m.extra["scene"] = scene.file.filename().string();
  return m;
}

void writeOutputs(const std::vector<fs::path>& outputs, const Scene& scene, const Sensor& sensor,
                  const RenderProgress& progress) {
  const Image image = sensor.developImage();
  const ImageMetadata metadata = metadataFor(scene, progress);
  for (const auto& path : outputs) writeImageFile(path, image, metadata, scene.render.exposure);
}

int runRender(const RenderFlags& flags) {
  Scene scene = loadScene(flags.scene);
  applyFlags(flags, scene.render);

  // Refuse bad outputs before tracing a single ray.
  std::vector<fs::path> outputs;
  for (const auto& o : flags.outputs) {
    const fs::path path(o);
    const std::string ext = path.extension().string();
    if (ext != ".exr" && ext != ".png")
      throw InputError("-o " + o, "unknown image format \"" + ext + "\" (expected .exr or .png)");
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    if (!fs::is_directory(dir)) throw InputError("-o " + o, "directory \"" + dir.string() + "\" does not exist");
    outputs.push_back(path);
  }

  try {
    (void)scene.camera();
  } catch (const InputError& e) {
    throw InputError(flags.scene, std::string("camera.") + e.what());
  }
  const unsigned threads = flags.threads.value_or(std::max(1u, std::thread::hardware_concurrency()));
  const RenderScene rs(scene);
  spdlog::info("{}: {} triangles in {} meshes, {} light triangles, {}x{} px, B = {}, {} on {} threads",
               flags.scene, rs.caster().triangles().size(), scene.meshes.size(), rs.lights().size(),
               scene.render.width, scene.render.height, scene.render.maxBounces,
               integratorName(scene.render.integrator), threads);
  if (scene.skippedDegenerateTriangles)
    spdlog::warn("{}: skipped {} zero-area triangles", flags.scene, scene.skippedDegenerateTriangles);

  Sensor sensor(scene.render.width, scene.render.height);
  ProgressBar bar(!flags.quiet);
  ProgressiveOptions options;
  options.samplesPerPixel = scene.render.samplesPerPixel;
  options.timeLimitSeconds = flags.timeLimit.value_or(0.0);
  options.snapshotEverySeconds = flags.snapshotEvery;
  options.onProgress = [&](const RenderProgress& p) { bar.update(p); };
  options.onSnapshot = [&](const Sensor& s, const RenderProgress& p) { writeOutputs(outputs, scene, s, p); };
  options.cancel = &gInterrupted;

  gInterrupted = false;
  std::signal(SIGINT, onSigint);
  tbb::task_arena arena{int(threads)};
  RenderOutcome outcome;
  arena.execute([&] { outcome = renderProgressive(rs, sensor, options); });
  std::signal(SIGINT, SIG_DFL);
  bar.finish();

  const RenderProgress& p = outcome.progress;
  writeOutputs(outputs, scene, sensor, p);
  const double seconds = std::max(p.elapsedSeconds, 1e-9);
  std::printf("samples per pixel: %llu%s\n", (unsigned long long)p.samplesPerPixelDone,
              outcome.interrupted ? " (interrupted)" : "");
  std::printf("paths:             %llu (%.3f M paths/s)\n", (unsigned long long)p.stats.paths,
              double(p.stats.paths) / seconds / 1e6);
  std::printf("rays:              %llu (%.3f M rays/s)\n", (unsigned long long)p.stats.rays,
              double(p.stats.rays) / seconds / 1e6);
  std::printf("light-hit fraction: %.2f %%\n",
              p.stats.paths ? 100.0 * double(p.stats.lightHits) / double(p.stats.paths) : 0.0);
  std::printf("dropped samples:   %llu\n", (unsigned long long)p.stats.dropped);
  std::printf("time:              %.2f s\n", p.elapsedSeconds);
  for (const auto& o : outputs) std::printf("wrote %s\n", o.c_str());
  return outcome.interrupted ? kInterrupted : kOk;
}

}  // namespace

Runner addRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a scene locally on this machine's cores");
  auto f = std::make_shared<RenderFlags>();
  cmd->add_option("scene", f->scene, "Scene file (JSON)")->required();
  cmd->add_option("-o,--output", f->outputs, "Output image (.exr: linear radiance; .png: exposed preview); repeatable")
      ->required();
  auto* spp = cmd->add_option("--spp", f->spp, "Samples per pixel (overrides the scene)")->check(CLI::Range(uint64_t(1), kMaxSamplesPerPixel));
  cmd->add_option("--time", f->timeLimit, "Render for this many seconds (with --spp: whichever comes first)")
      ->check(CLI::PositiveNumber);
  (void)spp;
  cmd->add_option("--threads", f->threads, "Threads (default: all cores)")->check(CLI::Range(1u, 4096u));
  cmd->add_option("--resolution", f->resolution, "Image size WIDTHxHEIGHT (overrides the scene)");
  cmd->add_option("--max-bounces", f->maxBounces, "Bounce limit B (overrides the scene)")->check(CLI::Range(0, kMaxBounces));
  cmd->add_option("--seed", f->seed, "Random seed (overrides the scene)");
  cmd->add_option("--integrator", f->integrator, "nee_mis or naive (overrides the scene)")
      ->check(CLI::IsMember({"nee_mis", "naive"}));
  cmd->add_option("--ev", f->ev, "Exposure compensation in stops for the PNG (overrides the scene)")
      ->check(CLI::Range(-64.0, 64.0));
  cmd->add_option("--snapshot-every", f->snapshotEvery, "Write the outputs every S seconds while rendering")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("-q,--quiet", f->quiet, "No progress bar");
  return [f] { return runRender(*f); };
}

}  // namespace lensfarm::cli
