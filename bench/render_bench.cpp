// Throughput of the renderer: paths/s and rays/s for one unit (1 sample per pixel over the whole
// frame) on all cores. The Embree scene is built once per benchmark, outside the timed loop.
//
//   make bench        (5 repetitions, medians reported)
//   build/bench/lensfarm-bench --benchmark_filter=Classic
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <thread>

#include "render/render_scene.h"
#include "render/unit_renderer.h"
#include "scene/scene_loader.h"

namespace lensfarm {
namespace {

void renderUnits(benchmark::State& state, const char* sceneName, int maxBounces, IntegratorKind integrator,
                 int resolution) {
  Scene scene = loadScene(std::string(LENSFARM_SOURCE_DIR "/scenes/") + sceneName);
  scene.render.maxBounces = maxBounces;
  scene.render.integrator = integrator;
  scene.render.width = scene.render.height = resolution;
  const RenderScene rs(scene);
  const int threads = int(std::max(1u, std::thread::hardware_concurrency()));
  tbb::task_arena arena{threads};
  PathStats stats;
  SensorBuffer buffer;
  uint64_t unit = 0;
  for (auto _ : state) {
    arena.execute([&] { renderUnit(rs, WorkUnit{unit, unit, 1}, buffer, stats); });
    ++unit;
    benchmark::DoNotOptimize(buffer.sums.data());
  }
  state.counters["paths/s"] = benchmark::Counter(double(stats.paths), benchmark::Counter::kIsRate);
  state.counters["rays/s"] = benchmark::Counter(double(stats.rays), benchmark::Counter::kIsRate);
  state.counters["rays/path"] = double(stats.rays) / double(std::max<uint64_t>(1, stats.paths));
  state.counters["threads"] = threads;
}

// The reference point: cornell-classic, 512x512, B = 3, NEE+MIS, all cores.
void BM_ClassicNeeMisB3(benchmark::State& s) { renderUnits(s, "cornell-classic.json", 3, IntegratorKind::kNeeMis, 512); }
void BM_ClassicNaiveB3(benchmark::State& s) { renderUnits(s, "cornell-classic.json", 3, IntegratorKind::kNaive, 512); }
// The seed scene (thin lens, rippled mirror, hidden light), B = 2 as in the report's Figure 4.
void BM_SeedNeeMisB2(benchmark::State& s) { renderUnits(s, "cornell-seed.json", 2, IntegratorKind::kNeeMis, 512); }
void BM_SeedNaiveB2(benchmark::State& s) { renderUnits(s, "cornell-seed.json", 2, IntegratorKind::kNaive, 512); }

BENCHMARK(BM_ClassicNeeMisB3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ClassicNaiveB3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SeedNeeMisB2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SeedNaiveB2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace lensfarm

BENCHMARK_MAIN();
