// Simulate only what a scene calls for: paths/s of the specialised path (effects compiled out
// where the scene does not need them) against the general path, side by side in one run.
//
//   build/bench/lensfarm-effects-bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "render/render_scene.h"
#include "render/unit_renderer.h"
#include "scene/scene_loader.h"

namespace lensfarm {
namespace {

enum Config { kPinholeDiffuse, kThinLensDiffuse, kRippledMirror, kSeedB1, kSeedB2, kSeedB3, kSeedB8 };

Scene configScene(Config config) {
  const std::string dir = LENSFARM_SOURCE_DIR "/scenes/";
  nlohmann::json j = nlohmann::json::parse(
      std::ifstream(dir + (config == kPinholeDiffuse || config == kThinLensDiffuse ? "cornell-classic.json" : "cornell-seed.json")));
  j["shapes"][0]["file"] = dir + "meshes/cornell-box.obj";
  j["render"]["resolution"] = {256, 256};
  if (config == kThinLensDiffuse) {
    j["camera"] = {{"type", "thin_lens"}, {"position", {0, 0, -2.9}}, {"look_at", {0, 0, 0}}, {"up", {0, -1, 0}},
                   {"sensor_width", 0.1}, {"focal_length", 0.095}, {"f_number", 2}};
  }
  if (config == kRippledMirror) j["camera"]["f_number"] = "infinity";  // the mirror alone
  const int bounces[] = {3, 3, 2, 1, 2, 3, 8};
  j["render"]["max_bounces"] = bounces[config];
  return parseScene(j.dump(), dir + "bench.json");
}

void BM_Paths(benchmark::State& state) {
  const Config config = Config(state.range(0));
  const bool general = state.range(1) != 0;
  const Scene scene = configScene(config);
  const RenderScene rs(scene, general);
  tbb::task_arena arena{int(std::max(1u, std::thread::hardware_concurrency()))};
  PathStats stats;
  SensorBuffer buffer;
  uint64_t unit = 0;
  for (auto _ : state) {
    arena.execute([&] { renderUnit(rs, WorkUnit{unit, unit, 1}, buffer, stats); });
    ++unit;
  }
  state.counters["paths/s"] = benchmark::Counter(double(stats.paths), benchmark::Counter::kIsRate);
  const char* names[] = {"pinhole diffuse", "thin lens diffuse", "rippled mirror", "seed B=1", "seed B=2", "seed B=3", "seed B=8"};
  state.SetLabel(std::string(names[config]) + (general ? " general" : " specialised") + " | " + rs.effects().summary());
}

BENCHMARK(BM_Paths)
    ->ArgsProduct({{kPinholeDiffuse, kThinLensDiffuse, kRippledMirror, kSeedB1, kSeedB2, kSeedB3, kSeedB8}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace lensfarm

BENCHMARK_MAIN();
