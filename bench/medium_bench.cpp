// Cost of the participating-media building blocks (common/medium/): one homogeneous
// transmittance, one chromatic free-flight sample, one HG sample, and a ratio-tracked and a
// delta-tracked transmittance through a 64^3 grid with a 16^3 majorant grid (a ray across it),
// and a ray that crosses only empty majorant cells.
//
//   build/bench/lensfarm-medium-bench [--benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <random>

#include "common/medium/grid_medium.h"
#include "common/medium/homogeneous_medium.h"

namespace lensfarm {
namespace {

struct Uniform {
  std::mt19937* engine;
  float operator()() const { return float((*engine)() >> 8) * 0x1.0p-24f; }
};

void BM_HomogeneousTransmittance(benchmark::State& state) {
  const HomogeneousMedium m(Spectrum(0.1f, 0.2f, 0.3f), Spectrum(0.5f, 0.6f, 0.7f), 0.0f);
  float d = 0.5f;
  for (auto _ : state) {
    benchmark::DoNotOptimize(m.transmittance(d));
    d += 1e-6f;
  }
}
BENCHMARK(BM_HomogeneousTransmittance);

void BM_ChromaticFreeFlight(benchmark::State& state) {
  const HomogeneousMedium m(Spectrum(0.1f, 0.2f, 0.0f), Spectrum(0.5f, 2.0f, 0.0f), 0.0f);
  std::mt19937 engine(1);
  const Uniform u{&engine};
  for (auto _ : state) benchmark::DoNotOptimize(m.sampleFreeFlight(1.5f, u(), u()));
}
BENCHMARK(BM_ChromaticFreeFlight);

void BM_HenyeyGreensteinSample(benchmark::State& state) {
  const HenyeyGreenstein hg(0.7f);
  std::mt19937 engine(1);
  const Uniform u{&engine};
  const Vec3 wo = glm::normalize(Vec3(1.0f, 2.0f, 3.0f));
  for (auto _ : state) benchmark::DoNotOptimize(hg.sample(wo, Vec2(u(), u())));
}
BENCHMARK(BM_HenyeyGreensteinSample);

GridMedium smokeGrid() {
  // A blob of density in the middle of the box, empty around it (as smoke usually is).
  const int n = 64;
  std::vector<float> density(size_t(n * n * n));
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const Vec3 p = (Vec3(float(x), float(y), float(z)) + 0.5f) / float(n) - 0.5f;
        density[size_t((z * n + y) * n + x)] = std::max(0.0f, 1.0f - 16.0f * glm::dot(p, p));
      }
  return GridMedium(Vec3(0.0f), Vec3(1.0f), glm::ivec3(n), std::move(density), Spectrum(0.5f),
                    Spectrum(2.0f, 2.5f, 3.0f), 0.0f, glm::ivec3(16));
}

// Times track(medium, o, dir, uniform) for one ray through smokeGrid().
template <typename Track>
void timeGridRay(benchmark::State& state, const Vec3& o, const Vec3& dir, Track track) {
  const GridMedium m = smokeGrid();
  std::mt19937 engine(1);
  const Uniform u{&engine};
  for (auto _ : state) benchmark::DoNotOptimize(track(m, o, dir, u));
}

const Vec3 kAcross(-0.1f, 0.45f, 0.52f);
const Vec3 kAcrossDir = glm::normalize(Vec3(1.0f, 0.05f, -0.03f));

void BM_GridRatioTracking(benchmark::State& state) {
  timeGridRay(state, kAcross, kAcrossDir, [](const GridMedium& m, const Vec3& o, const Vec3& d, const Uniform& u) {
    return m.ratioTrackingTransmittance(o, d, 2.0f, u);
  });
}
BENCHMARK(BM_GridRatioTracking);

void BM_GridDeltaTracking(benchmark::State& state) {
  timeGridRay(state, kAcross, kAcrossDir, [](const GridMedium& m, const Vec3& o, const Vec3& d, const Uniform& u) {
    return m.deltaTrackingTransmittance(o, d, 2.0f, 1, u);
  });
}
BENCHMARK(BM_GridDeltaTracking);

void BM_GridEmptyRay(benchmark::State& state) {
  // A ray through the empty corner only: the DDA alone, no tracking step.
  timeGridRay(state, Vec3(-0.1f, 0.02f, 0.02f), Vec3(1.0f, 0.0f, 0.0f),
              [](const GridMedium& m, const Vec3& o, const Vec3& d, const Uniform& u) {
                return m.ratioTrackingTransmittance(o, d, 2.0f, u);
              });
}
BENCHMARK(BM_GridEmptyRay);

}  // namespace
}  // namespace lensfarm

BENCHMARK_MAIN();
