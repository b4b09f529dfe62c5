// Accuracy per second: the three goals set for it, measured on this machine with
// the real renderer (renderUnit, render/unit_renderer.h, driven unit by unit by the progressive
// loop of study/progressive.h, in a TBB arena of --threads threads):
//
//   1. time to 1.7 % relative RMSE: cornell-classic, 256 x 256, B = 3, NEE + MIS, Sobol. Goal <= 2.4 s.
//   2. the 2013 report's Figure 4 job: cornell-seed, 800 x 800, B = 2, the naive estimator, 1.2e8 paths
//      (187.5 samples per pixel, rounded up to 188), in units of the automatic size as
//      `lensfarm render` would. Goal <= 10 s. Its relative RMSE is measured as well.
//   3. NEE + MIS on the same scene, resolution and B: the time at which its relative RMSE first
//      falls to the naive job's (the median of goal 2's runs). Goal <= 1 s.
//
// Error: the relative RMSE of film/error_metrics.h (RMSE over pixels and channels / mean of the
// reference) of the developed sensor image against a converged reference: NEE + MIS with Sobol
// samples at --reference-spp-256 / --reference-spp-800 samples per pixel, with a seed of its own
// (study/progressive.h: referenceImage), cached in --cache. Its own estimated error
// (film/convergence.h) is printed: it adds in quadrature to every error measured against it, so
// the measured errors are, if anything, pessimistic.
//
// Time: tracing and accumulation only (renderUnit + Sensor::add): never scene loading, image
// development or error measurement. For goals 1 and 3 the error is measured after every unit
// (4 and 1 samples per pixel) and the time given is the traced time at the first unit boundary
// whose image is within the target: nothing is interpolated.
//
// Each goal runs --repeat times with seeds scene seed + 1 ... + repeat (the reference uses the
// scene seed ^ 0x5eed5eed5eed5eed); the table gives medians with min .. max, and pixel-samples/s
// and rays/s (render/integrator.h PathStats: every camera, scattered and shadow ray).
//
// Goal 3 runs the default (render.light_tracing auto: off); --light-tracing on and
// --light-tracing-ratio measure the light tracer (render/light_tracer.h) on the 2013 report's caustic.
//
//   build/bench/lensfarm-accuracy-goals [--repeat 5] [--threads N] [--cache DIR] [--only 1|2|3]
//                                       [--reference-spp-256 4096] [--reference-spp-800 1024] [--quick]
//                                       [--light-tracing auto|on|off] [--light-tracing-ratio R]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "client/study/progressive.h"
#include "common/film/error_metrics.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {
namespace {

using Clock = std::chrono::steady_clock;

// The goals' settings; --quick shrinks them to a smoke test of seconds (thresholds then meaningless).
struct Settings {
  int side1 = 256;
  double target1 = 0.017;
  uint32_t unit1 = 4;
  uint64_t cap1 = 4096;  // samples per pixel at which goal 1 gives up
  int side23 = 800;
  double paths2 = 1.2e8;
  uint32_t unit3 = 1;
  uint64_t cap3 = 1024;
  uint64_t referenceSpp1 = 4096, referenceSpp23 = 1024;
};
const Settings kQuick{32, 0.05, 4, 1024, 32, 65536.0, 1, 1024, 1024, 1024};

struct Run {
  double seconds = 0.0, error = 0.0, meanRatio = 0.0;
  uint64_t spp = 0;
  PathStats stats;
  bool reached = true;
};

// Renders `scene` (units of scene.render.samplesPerUnit) up to `maxSpp` samples per pixel. With
// `target` > 0 the error is measured after every unit and rendering stops at the first unit
// within it; otherwise only the finished image is measured.
Run measure(Scene scene, const Image& reference, uint64_t maxSpp, double target, unsigned threads) {
  study::ProgressiveRun run;
  run.firstCheckpoint = run.maxSamples = maxSpp;
  run.everyUnit = target > 0.0;
  run.threads = threads;
  const ExposureSettings exposure = scene.render.exposure;
  Run r;
  const study::Checkpoint last = study::renderProgressive(std::move(scene), run, [&](const study::Checkpoint& c) {
    const ImageError e = compareImages(c.image, reference, exposure);
    r.error = e.relativeRmse;
    r.meanRatio = e.meanRatio;
    return e.relativeRmse > target;
  });
  r.seconds = last.seconds;
  r.spp = last.samplesPerPixel;
  r.stats = last.stats;
  r.reached = target <= 0.0 || r.error <= target;
  return r;
}

struct Spread {
  double median = 0.0, min = 0.0, max = 0.0;
};

Spread spread(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return {n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]), v.front(), v.back()};
}

// The runs of one goal, printed one line each as they finish.
struct Goal {
  std::vector<Run> runs;
  Spread of(double (*field)(const Run&)) const {
    std::vector<double> v;
    for (const Run& r : runs) v.push_back(field(r));
    return spread(v);
  }
  Spread seconds() const {
    return of([](const Run& r) { return r.seconds; });
  }
  Spread error() const {
    return of([](const Run& r) { return r.error; });
  }
  Spread spp() const {
    return of([](const Run& r) { return double(r.spp); });
  }
  Spread pathRate() const {
    return of([](const Run& r) { return double(r.stats.paths) / r.seconds; });
  }
  Spread rayRate() const {
    return of([](const Run& r) { return double(r.stats.rays) / r.seconds; });
  }
  size_t missed() const {
    return size_t(std::count_if(runs.begin(), runs.end(), [](const Run& r) { return !r.reached; }));
  }
};

Goal repeatRuns(const char* name, const Scene& scene, int repeat, const std::function<Run(Scene)>& once) {
  Goal g;
  for (int k = 0; k < repeat; ++k) {
    Scene s = scene;
    s.render.seed = scene.render.seed + uint64_t(k) + 1;
    const Run r = once(s);
    std::printf(
        "  %s run %d/%d (seed %llu): %.3f s traced, %llu spp, %llu paths, rel. RMSE %.2f %%%s, mean ratio "
        "%.4f, %.3f M pixel-samples/s, %.2f M rays/s\n",
        name, k + 1, repeat, static_cast<unsigned long long>(s.render.seed), r.seconds,
        static_cast<unsigned long long>(r.spp), static_cast<unsigned long long>(r.stats.paths), 100.0 * r.error,
        r.reached ? "" : " (target not reached)", r.meanRatio, double(r.stats.paths) / r.seconds / 1e6,
        double(r.stats.rays) / r.seconds / 1e6);
    std::fflush(stdout);
    g.runs.push_back(r);
  }
  return g;
}

Image reference(const Scene& scene, uint64_t spp, const std::string& cache, unsigned threads, const char* what,
                double& estimated) {
  const auto start = Clock::now();
  Image image = study::referenceImage(scene, spp, cache, &estimated, threads);
  std::printf(
      "reference %s: NEE + MIS, Sobol, %llu spp, seed %llu ^ 0x5eed5eed5eed5eed, estimated rel. error "
      "%.3f %%, %.1f s (rendered or read from %s)\n",
      what, static_cast<unsigned long long>(spp), static_cast<unsigned long long>(scene.render.seed), 100.0 * estimated,
      std::chrono::duration<double>(Clock::now() - start).count(), cache.c_str());
  std::fflush(stdout);
  return image;
}

std::string seconds(const Goal& g) {
  const Spread s = g.seconds();
  char text[128];
  std::snprintf(text, sizeof text, "%s%.2f s (%.2f .. %.2f)", g.missed() ? "> " : "", s.median, s.min, s.max);
  return text;
}

void row(const char* goal, const std::string& measured, const char* threshold, const char* met, const Goal& g) {
  std::printf("| %s | %s | %s | %s | %.0f | %.3f | %.2f |\n", goal, measured.c_str(), threshold, met, g.spp().median,
              g.pathRate().median / 1e6, g.rayRate().median / 1e6);
}

int run(int argc, char** argv) {
  CLI::App app{"lensfarm accuracy goals: time to an error against a converged reference"};
  int repeat = 5, only = 0;
  unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::string cache = LENSFARM_BINARY_DIR "/accuracy-goals-cache";
  bool quick = false;
  double naiveError = 0.0;
  std::string lightTracing = "auto";
  double lightTracingRatio = 0.0;
  Settings set;
  app.add_option("--repeat", repeat, "Runs per goal (seeds differ); medians are reported")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", threads)->capture_default_str()->check(CLI::Range(1u, 1024u));
  app.add_option("--cache", cache, "Where converged references are kept")->capture_default_str();
  app.add_option("--only", only, "Run one goal (3 runs goal 2 too, for its error, unless --naive-error)")
      ->check(CLI::Range(1, 3));
  app.add_option("--naive-error", naiveError, "Goal 3's target instead of goal 2's measured median (a fraction)")
      ->check(CLI::PositiveNumber);
  auto* ref256 = app.add_option("--reference-spp-256", set.referenceSpp1, "Reference samples per pixel, goal 1")
                     ->capture_default_str()
                     ->check(CLI::Range(16, 1 << 20));
  auto* ref800 = app.add_option("--reference-spp-800", set.referenceSpp23, "Reference samples per pixel, goals 2 and 3")
                     ->capture_default_str()
                     ->check(CLI::Range(16, 1 << 20));
  app.add_option("--light-tracing", lightTracing, "Goal 3's render.light_tracing")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "on", "off"}));
  app.add_option("--light-tracing-ratio", lightTracingRatio, "Goal 3's light paths per camera path (0: the scene's)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--quick", quick, "Tiny images (32 x 32) and references: a smoke test of seconds");
  CLI11_PARSE(app, argc, argv);
  if (quick) {
    const Settings given = set;
    set = kQuick;
    if (ref256->count()) set.referenceSpp1 = given.referenceSpp1;
    if (ref800->count()) set.referenceSpp23 = given.referenceSpp23;
  }
  const auto start = Clock::now();
  const bool want1 = only == 0 || only == 1, want2 = only == 0 || only == 2 || (only == 3 && naiveError == 0.0),
             want3 = only == 0 || only == 3;
  std::printf("accuracy goals%s: %u threads, %d runs per goal, rel. RMSE against a converged reference\n",
              quick ? " (--quick: tiny settings, thresholds do not apply)" : "", threads, repeat);

  Goal g1, g2, g3;
  double refError1 = 0.0, refError23 = 0.0;
  if (want1) {
    Scene scene = loadScene(LENSFARM_SOURCE_DIR "/scenes/cornell-classic.json");
    scene.render.width = scene.render.height = set.side1;
    scene.render.maxBounces = 3;
    scene.render.integrator = IntegratorKind::kNeeMis;
    scene.render.sampler = SamplerKind::kSobol;
    scene.render.samplesPerUnit = set.unit1;
    const Image ref = reference(scene, set.referenceSpp1, cache, threads, "cornell-classic, B = 3", refError1);
    std::printf("goal 1: cornell-classic %dx%d, B = 3, NEE + MIS, Sobol, units of %u spp, time to %.2f %%\n", set.side1,
                set.side1, set.unit1, 100.0 * set.target1);
    g1 = repeatRuns("goal 1", scene, repeat, [&](Scene s) { return measure(s, ref, set.cap1, set.target1, threads); });
  }

  Scene seed = loadScene(LENSFARM_SOURCE_DIR "/scenes/cornell-seed.json");
  seed.render.width = seed.render.height = set.side23;
  seed.render.maxBounces = 2;
  seed.render.sampler = SamplerKind::kSobol;
  const double pixels = double(set.side23) * set.side23;
  const uint64_t jobSpp = uint64_t(std::ceil(set.paths2 / pixels));
  Image ref23;
  if (want2 || want3) ref23 = reference(seed, set.referenceSpp23, cache, threads, "cornell-seed, B = 2", refError23);
  if (want2) {
    Scene scene = seed;
    scene.render.integrator = IntegratorKind::kNaive;
    scene.render.samplesPerPixel = jobSpp;
    scene.render.samplesPerUnit = unitSize(scene.render);
    std::printf(
        "goal 2: cornell-seed %dx%d, B = 2, naive, Sobol, %.4g paths requested = %.4g spp, rendered %llu spp in "
        "units of %u spp\n",
        set.side23, set.side23, set.paths2, set.paths2 / pixels, static_cast<unsigned long long>(jobSpp),
        scene.render.samplesPerUnit);
    g2 = repeatRuns("goal 2", scene, repeat, [&](Scene s) { return measure(s, ref23, jobSpp, 0.0, threads); });
    if (naiveError == 0.0) naiveError = g2.error().median;
  }
  if (want3) {
    Scene scene = seed;
    scene.render.integrator = IntegratorKind::kNeeMis;
    scene.render.samplesPerUnit = set.unit3;
    scene.render.lightTracing = lightTracing == "on"    ? LightTracingMode::kOn
                                : lightTracing == "off" ? LightTracingMode::kOff
                                                        : LightTracingMode::kAuto;
    if (lightTracingRatio > 0.0) scene.render.lightTracingRatio = lightTracingRatio;
    std::printf("goal 3: light tracing %s, %.3g light paths per camera path\n", lightTracing.c_str(),
                scene.render.lightTracingRatio);
    std::printf(
        "goal 3: cornell-seed %dx%d, B = 2, NEE + MIS, Sobol, units of %u spp, time to the naive job's %.2f %%\n",
        set.side23, set.side23, set.unit3, 100.0 * naiveError);
    g3 = repeatRuns("goal 3", scene, repeat, [&](Scene s) { return measure(s, ref23, set.cap3, naiveError, threads); });
  }

  std::printf(
      "\n| goal | measured: median (min .. max) of %d | goal | met | spp (median) | M pixel-samples/s | M rays/s |\n",
      repeat);
  std::printf("|---|---|---|---|---|---|---|\n");
  const auto met = [&](const Goal& g, double limit) {
    return quick ? "n/a" : !g.missed() && g.seconds().median <= limit ? "yes" : "no";
  };
  char what[256];
  if (want1) {
    std::snprintf(what, sizeof what, "1. time to %.2f %% rel. RMSE, cornell-classic %d², B = 3, NEE + MIS",
                  100.0 * set.target1, set.side1);
    row(what, seconds(g1), "<= 2.4 s", met(g1, 2.4), g1);
  }
  if (want2) {
    std::snprintf(what, sizeof what, "2. Figure 4 job: cornell-seed %d², B = 2, naive, %llu paths", set.side23,
                  static_cast<unsigned long long>(g2.runs.front().stats.paths));
    row(what, seconds(g2), "<= 10 s", met(g2, 10.0), g2);
    const Spread e = g2.error();
    char text[160];
    std::snprintf(text, sizeof text, "%.2f %% (%.2f .. %.2f); %.2f %% without the reference's own error",
                  100.0 * e.median, 100.0 * e.min, 100.0 * e.max,
                  100.0 * std::sqrt(std::max(0.0, e.median * e.median - refError23 * refError23)));
    row("2. its rel. RMSE", text, "goal 3's target", "", g2);
  }
  if (want3) {
    std::snprintf(what, sizeof what, "3. NEE + MIS to the naive job's %.2f %%, cornell-seed %d², B = 2",
                  100.0 * naiveError, set.side23);
    row(what, seconds(g3), "<= 1 s", met(g3, 1.0), g3);
  }
  std::printf(
      "\nThe references' own estimated errors add in quadrature to the errors measured against them (for goal\n"
      "3 equally to both sides of the comparison with the naive job):\n");
  if (want1)
    std::printf("  cornell-classic %d²: %.3f %%, %.2f of goal 1's target\n", set.side1, 100.0 * refError1,
                refError1 / set.target1);
  if (want3 || want2)
    std::printf("  cornell-seed %d²: %.3f %%, %.2f of the naive job's error\n", set.side23, 100.0 * refError23,
                refError23 / naiveError);
  std::printf("\ntotal wall time %.1f s\n", std::chrono::duration<double>(Clock::now() - start).count());
  return 0;
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) { return lensfarm::run(argc, argv); }
