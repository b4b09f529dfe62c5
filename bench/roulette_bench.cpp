// Russian roulette by error per second: every shipped scene (scenes/*.json)
// rendered with each roulette rule (render.russian_roulette: off, max, throughput; scene.h
// RouletteRule) at the same samples per pixel, and its efficiency 1 / (relative MSE x seconds)
// (the inverse of the time the estimator needs for a given relative MSE, since an unbiased
// estimator's MSE falls as 1/time) compared with roulette off.
//
// Error without a reference: every rule is unbiased with the same expectation, so two renders
// with independent seeds differ by noise alone, and the relative MSE of one render is half the
// relative MSE between the two (film/error_metrics.h compareImages, relative to the second's
// mean). A converged reference would add its own error to every rule alike (at 1024 spp it was
// 20-50 % on the scenes with small bright lights, burying the differences) and take longer.
// Time: tracing and accumulation only (study/progressive.h), the mean of the pair. Each scene's
// resolution is scaled so its longer side is --side. The rules run in rotated order within each
// of --repeat rounds (seeds 2r + 1 and 2r + 2 past the scene's), so a slow spell of the shared
// machine falls on all of them; the table gives medians over the rounds.
//
//   build/bench/lensfarm-roulette-bench [--side 128] [--spp 64] [--repeat 5] [--threads N] [--scene NAME ...]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "client/study/progressive.h"
#include "common/film/error_metrics.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {
namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Rule {
  RouletteRule rule;
  std::vector<double> seconds, error, efficiency, raysPerPath;
};

int run(int argc, char** argv) {
  CLI::App app{"Russian roulette rules by error per second on every shipped scene"};
  int side = 128, repeat = 5;
  uint64_t spp = 64;
  unsigned threads = 0;
  std::vector<std::string> names;
  app.add_option("--side", side, "Longer image side in pixels")->capture_default_str()->check(CLI::Range(8, 2048));
  app.add_option("--spp", spp, "Samples per pixel of each measured render")->capture_default_str();
  app.add_option("--repeat", repeat, "Rounds (seeds); medians are reported")->capture_default_str();
  app.add_option("--threads", threads, "0: every core")->capture_default_str();
  app.add_option("--scene", names, "Scene files in scenes/ (default: every one)");
  CLI11_PARSE(app, argc, argv);
  if (names.empty()) {
    for (const auto& e : std::filesystem::directory_iterator(LENSFARM_SOURCE_DIR "/scenes"))
      if (e.path().extension() == ".json") names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
  }

  std::printf("| scene | B | rule | rel. RMSE | seconds | rays/path | 1/(rel. MSE x s) | vs off |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const std::string& name : names) {
    Scene scene = loadScene(std::string(LENSFARM_SOURCE_DIR "/scenes/") + name);
    RenderSettings& s = scene.render;
    const double scale = double(side) / double(std::max(s.width, s.height));
    s.width = std::max(1, int(std::lround(s.width * scale)));
    s.height = std::max(1, int(std::lround(s.height * scale)));
    s.targetError = s.timeLimitSeconds = 0.0;
    s.samplesPerUnit = 16;
    std::vector<Rule> rules{{RouletteRule::kOff, {}, {}, {}, {}},
                            {RouletteRule::kMax, {}, {}, {}, {}},
                            {RouletteRule::kThroughput, {}, {}, {}, {}}};
    for (int round = 0; round < repeat; ++round)
      for (size_t j = 0; j < rules.size(); ++j) {
        Rule& r = rules[(j + size_t(round)) % rules.size()];
        study::Checkpoint pair[2];
        for (int k = 0; k < 2; ++k) {
          Scene measured = scene;
          measured.render.roulette = r.rule;
          measured.render.seed = s.seed + 2 * uint64_t(round) + uint64_t(k) + 1;
          study::ProgressiveRun progressive;
          progressive.firstCheckpoint = progressive.maxSamples = spp;
          progressive.threads = threads;
          pair[k] = study::renderProgressive(std::move(measured), progressive);
        }
        const double error = compareImages(pair[0].image, pair[1].image, s.exposure).relativeRmse / std::sqrt(2.0);
        const double seconds = 0.5 * (pair[0].seconds + pair[1].seconds);
        const PathStats& stats = pair[0].stats;
        r.seconds.push_back(seconds);
        r.error.push_back(error);
        r.efficiency.push_back(1.0 / (error * error * seconds));
        r.raysPerPath.push_back(double(stats.rays) / double(std::max<uint64_t>(1, stats.paths)));
      }
    const double off = median(rules[0].efficiency);
    for (const Rule& r : rules)
      std::printf("| %s | %d | %s | %.2f %% | %.3f | %.2f | %.4g | %.3f |\n", name.c_str(), s.maxBounces,
                  rouletteName(r.rule), 100.0 * median(r.error), median(r.seconds), median(r.raysPerPath),
                  median(r.efficiency), median(r.efficiency) / off);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) { return lensfarm::run(argc, argv); }
