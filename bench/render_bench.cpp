// Throughput of the renderer: paths/s and rays/s for one unit (16 samples per pixel over the whole
// frame, one 16-wide packet per pixel) on all cores. The Embree scene is built once per benchmark,
// outside the timed loop.
//
// BM_Paths compares, per scene, the path specialised on the scene's effects with the general one.
//
//   make bench        (5 repetitions, medians reported)
//   build/bench/lensfarm-bench --benchmark_filter=Classic
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {
namespace {

// Traces one unit (16 spp over the whole frame) per iteration on all cores and reports paths/s,
// rays/s and rays per path. The Embree scene is built by the caller, outside the timed loop.
void traceUnits(benchmark::State& state, const RenderScene& rs, RayGrouping grouping = RayGrouping::kPackets) {
  constexpr uint32_t kUnitSamples = 16;
  const int threads = int(std::max(1u, std::thread::hardware_concurrency()));
  tbb::task_arena arena{threads};
  PathStats stats;
  SensorBuffer buffer;
  uint64_t unit = 0;
  for (auto _ : state) {
    arena.execute([&] {
      renderUnit(rs, WorkUnit{unit, unit * kUnitSamples, kUnitSamples}, buffer, stats, nullptr, grouping);
    });
    ++unit;
    benchmark::DoNotOptimize(buffer.sums.data());
  }
  state.counters["paths/s"] = benchmark::Counter(double(stats.paths), benchmark::Counter::kIsRate);
  state.counters["rays/s"] = benchmark::Counter(double(stats.rays), benchmark::Counter::kIsRate);
  state.counters["rays/path"] = double(stats.rays) / double(std::max<uint64_t>(1, stats.paths));
  state.counters["threads"] = threads;
}

void renderUnits(benchmark::State& state, const char* sceneName, int maxBounces, IntegratorKind integrator,
                 int resolution, RayGrouping grouping = RayGrouping::kPackets) {
  Scene scene = loadScene(std::string(LENSFARM_SOURCE_DIR "/scenes/") + sceneName);
  scene.render.maxBounces = maxBounces;
  scene.render.integrator = integrator;
  scene.render.width = scene.render.height = resolution;
  traceUnits(state, RenderScene(scene), grouping);
}

// The performance goals' reference point: cornell-classic, 512x512, B = 3, NEE+MIS, all cores.
void BM_ClassicNeeMisB3(benchmark::State& s) {
  renderUnits(s, "cornell-classic.json", 3, IntegratorKind::kNeeMis, 512);
}
// The same with one ray per Embree call (the reference tracer): what packets gain.
void BM_ClassicNeeMisB3SingleRays(benchmark::State& s) {
  renderUnits(s, "cornell-classic.json", 3, IntegratorKind::kNeeMis, 512, RayGrouping::kSingleRays);
}
void BM_ClassicNaiveB3(benchmark::State& s) { renderUnits(s, "cornell-classic.json", 3, IntegratorKind::kNaive, 512); }
// The 2013 report's scene (thin lens, rippled mirror, hidden light), B = 2 as in its Figure 4.
void BM_SeedNeeMisB2(benchmark::State& s) { renderUnits(s, "cornell-seed.json", 2, IntegratorKind::kNeeMis, 512); }
void BM_SeedNaiveB2(benchmark::State& s) { renderUnits(s, "cornell-seed.json", 2, IntegratorKind::kNaive, 512); }

BENCHMARK(BM_ClassicNeeMisB3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ClassicNeeMisB3SingleRays)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ClassicNaiveB3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SeedNeeMisB2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SeedNaiveB2)->Unit(benchmark::kMillisecond)->UseRealTime();

enum Config { kPinholeDiffuse, kThinLensDiffuse, kRippledMirror, kSeedB1, kSeedB2, kSeedB3, kSeedB8 };

Scene configScene(Config config) {
  const std::string dir = LENSFARM_SOURCE_DIR "/scenes/";
  nlohmann::json j = nlohmann::json::parse(std::ifstream(
      dir + (config == kPinholeDiffuse || config == kThinLensDiffuse ? "cornell-classic.json" : "cornell-seed.json")));
  j["shapes"][0]["file"] = dir + "meshes/cornell-box.obj";
  j["render"]["resolution"] = {256, 256};
  if (config == kThinLensDiffuse) {
    j["camera"] = {{"type", "thin_lens"}, {"position", {0, 0, -2.9}}, {"look_at", {0, 0, 0}}, {"up", {0, -1, 0}},
                   {"sensor_width", 0.1}, {"focal_length", 0.095},    {"f_number", 2}};
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
  traceUnits(state, rs);
  const char* names[] = {"pinhole diffuse", "thin lens diffuse", "rippled mirror", "seed B=1",
                         "seed B=2",        "seed B=3",          "seed B=8"};
  state.SetLabel(std::string(names[config]) + (general ? " general" : " specialised") + " | " + rs.effects().summary());
}

// Simulate only what a scene calls for: the specialised path (effects compiled out where the
// scene does not need them) against the general path, side by side.
BENCHMARK(BM_Paths)
    ->ArgsProduct({{kPinholeDiffuse, kThinLensDiffuse, kRippledMirror, kSeedB1, kSeedB2, kSeedB3, kSeedB8}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One row per material, light and camera kind: every shipped scene with its own
// settings (materials: Lambertian, rippled mirror, dielectric, conductor, principled and textured
// glTF; cameras: pinhole, thin lens, real lens; lights: quads, the sky and sun) at 128 pixels on
// its longer side, and cornell-classic with its quad light swapped for each light kind that no
// shipped scene has (point, spot, directional). Rows, not goals: a change that slows one kind
// shows here.
const char* const kShippedScenes[] = {"bokeh-lights.json",           "cornell-animated.json", "cornell-classic.json",
                                      "cornell-glass-metal.json",    "cornell-glass.json",    "cornell-real-lens.json",
                                      "cornell-seed-fast-lens.json", "cornell-seed.json",     "glass-metal-sky.json",
                                      "night-lights-starburst.json", "textured-spheres.json"};

Scene smallScene(nlohmann::json j, const std::string& path) {
  const double scale =
      128.0 / double(std::max(j["render"]["resolution"][0].get<int>(), j["render"]["resolution"][1].get<int>()));
  j["render"]["resolution"] = {std::max(1, int(std::lround(j["render"]["resolution"][0].get<int>() * scale))),
                               std::max(1, int(std::lround(j["render"]["resolution"][1].get<int>() * scale)))};
  return parseScene(j.dump(), path);
}

void BM_ShippedScene(benchmark::State& state) {
  const std::string path = std::string(LENSFARM_SOURCE_DIR "/scenes/") + kShippedScenes[state.range(0)];
  const Scene scene = smallScene(nlohmann::json::parse(std::ifstream(path)), path);
  const RenderScene rs(scene);
  traceUnits(state, rs);
  state.SetLabel(std::string(kShippedScenes[state.range(0)]) + " | " + rs.effects().summary());
}
BENCHMARK(BM_ShippedScene)
    ->DenseRange(0, int(std::size(kShippedScenes)) - 1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_LightKind(benchmark::State& state) {
  const std::string path = LENSFARM_SOURCE_DIR "/scenes/cornell-classic.json";
  nlohmann::json j = nlohmann::json::parse(std::ifstream(path));
  const nlohmann::json lights[] = {
      {{"type", "point"}, {"position", {0, -0.9, 0}}, {"intensity", 2}},
      {{"type", "spot"}, {"position", {0, -0.9, 0}}, {"look_at", {0, 1, 0}}, {"intensity", 4}, {"cone_angle", 45}},
      {{"type", "directional"}, {"direction", {0.2, -0.3, -1}}, {"irradiance", 3}, {"angular_diameter", 0.53}}};
  j["lights"] = nlohmann::json::array({lights[state.range(0)]});
  const Scene scene = smallScene(j, path);
  const RenderScene rs(scene);
  traceUnits(state, rs);
  state.SetLabel(lights[state.range(0)]["type"].get<std::string>() + " light in cornell-classic");
}
BENCHMARK(BM_LightKind)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace lensfarm

BENCHMARK_MAIN();
