#pragma once
// Small pieces the Coordinator tests share (coordinator, liveness, memory, state): a worker's
// registration and a unit result of constant sums, so accumulation is tested without rendering.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <string>

#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "tests/test_support.h"

namespace lensfarm::test {

// A worker of `threads` threads, of this build's protocol and renderer version.
inline WorkerInfo workerInfo(const std::string& name, uint32_t threads = 1) {
  return WorkerInfo{name, threads, kProtocolVersion, kRendererVersion};
}

// The result of lease `g` for `worker` on a width x height frame (4 x 3 unless given), every sum
// `value`, one path a pixel and 3 rays a path for each sample, rendered in `renderSeconds`.
inline UnitResult resultFor(const std::string& worker, const LeaseGrant& g, double value, double renderSeconds = 0.0,
                            int width = 4, int height = 3) {
  UnitResult r = resultForLease(worker, g);
  r.buffer = SensorBuffer(width, height);
  std::fill(r.buffer.sums.begin(), r.buffer.sums.end(), value);
  r.stats.paths = uint64_t(width) * uint64_t(height) * g.unit.sampleCount;
  r.stats.rays = 3 * r.stats.paths;
  r.renderSeconds = renderSeconds;
  return r;
}

// `scene` at 4 x 3 pixels, `spp` samples a pixel in units of `perUnit`, as a job's spec.
inline JobSpec specFor(nlohmann::json scene, uint64_t spp, uint32_t perUnit) {
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = perUnit;
  scene["render"]["resolution"] = {4, 3};
  JobSpec spec;
  spec.sceneName = "test.json";
  spec.sceneJson = scene.dump();
  return spec;
}
// The minimal scene (test_support.h) so.
inline JobSpec minimalSpec(uint64_t spp, uint32_t perUnit = 1) { return specFor(minimalSceneJson(), spp, perUnit); }

// The kind of the FarmError `call` throws (a test failure if it throws none).
inline FarmError::Kind kindOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const FarmError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no FarmError";
  return FarmError::Kind::kInvalidArgument;
}

}  // namespace lensfarm::test
