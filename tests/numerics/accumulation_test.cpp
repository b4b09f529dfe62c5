// Long accumulation and non-finite containment.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>

#include "common/film/sensor.h"
#include "common/render/unit_renderer.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

TEST(LongAccumulation, ABillionSamplesOfAConstantIntoOnePixel) {
  // As the renderer does: each unit sums its samples in a double, the sensor adds units with
  // compensated summation. 1000 units of 10^6 samples of 0.1.
  const double c = 0.1;
  const uint64_t perUnit = 1'000'000, units = 1000;
  Sensor sensor(1, 1);
  SensorBuffer unit(1, 1);
  for (uint64_t u = 0; u < units; ++u) {
    double sum = 0.0;
    for (uint64_t s = 0; s < perUnit; ++s) sum += c;
    unit.sums = {sum, sum, sum};
    unit.samples = {uint32_t(perUnit)};
    sensor.add(unit);
  }
  EXPECT_EQ(sensor.totalSamples(), perUnit * units);
  const long double exact = static_cast<long double>(c);  // the mean of identical samples
  EXPECT_LT(std::abs((static_cast<long double>(sensor.mean(0, 0).x) - exact) / exact), 1e-9L);
}

TEST(LongAccumulation, AJobOfAHundredThousandUnitsInTheCoordinator) {
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {1, 1};
  scene["render"]["samples_per_pixel"] = 100000;
  scene["render"]["samples_per_unit"] = 1;
  Coordinator c;
  const std::string job = c.submit(JobSpec{"long.json", scene.dump(), {}, {}, std::nullopt}, 0).id;
  const std::string w = c.registerWorker(WorkerInfo{"w", 1, kProtocolVersion, kRendererVersion});
  const double value = 0.1;
  while (auto g = c.lease(w, 0)) {
    UnitResult r;
    r.workerId = w;
    r.leaseId = g->leaseId;
    r.jobId = g->jobId;
    r.unitIndex = g->unit.index;
    r.buffer = SensorBuffer(1, 1);
    r.buffer.sums = {value, value, value};
    r.stats.paths = g->unit.sampleCount;  // one pixel
    c.acceptResult(std::move(r));
  }
  ASSERT_EQ(c.job(job).state, JobState::kDone);
  const Sensor sensor = Sensor::deserialize(c.sensorState(job));
  EXPECT_EQ(sensor.totalSamples(), 100000u);
  EXPECT_LT(std::abs(sensor.mean(0, 0).x - value) / value, 1e-9);
  EXPECT_EQ(c.image(job).image.rgb[0], float(value));
}

TEST(NonFinite, InjectedNaNAndInfAreCountedDroppedAndNeverWritten) {
  for (double poison : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    test::TempDir dir;
    Scene scene = test::loadSceneJson(dir, test::minimalSceneJson());
    // A light that emits NaN (or Inf): impossible through a scene file, so injected here.
    for (Material& m : scene.materials)
      if (m.isEmissive()) m.emission = Spectrum(float(poison));
    const RenderScene rs(scene);
    SensorBuffer buffer;
    PathStats stats;
    tbb::task_arena arena{2};
    arena.execute([&] { ASSERT_TRUE(renderUnit(rs, WorkUnit{0, 0, 4}, buffer, stats)); });
    EXPECT_GT(stats.dropped, 0u) << poison;
    EXPECT_EQ(stats.paths, 16u * 16u * 4u);
    for (double v : buffer.sums) ASSERT_TRUE(std::isfinite(v)) << poison;
  }
}

}  // namespace
}  // namespace lensfarm
