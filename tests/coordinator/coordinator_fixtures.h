#pragma once
// Small pieces the Coordinator tests share (coordinator, liveness, memory, state): a worker's
// registration and a unit result of constant sums, so accumulation is tested without rendering.
#include <algorithm>
#include <string>

#include "coordinator.h"
#include "util/version.h"

namespace lensfarm::test {

// A worker of one thread, of this build's protocol and renderer version.
inline WorkerInfo workerInfo(const std::string& name) { return WorkerInfo{name, 1, kProtocolVersion, kRendererVersion}; }

// The result of lease `g` for `worker` on a 4 x 3 frame, every sum `value`, 12 paths and 36 rays a
// sample, rendered in `renderSeconds`.
inline UnitResult resultFor(const std::string& worker, const LeaseGrant& g, double value, double renderSeconds = 0.0) {
  UnitResult r = resultForLease(worker, g);
  r.buffer = SensorBuffer(4, 3);
  std::fill(r.buffer.sums.begin(), r.buffer.sums.end(), value);
  r.stats.paths = 12 * g.unit.sampleCount;
  r.stats.rays = 3 * r.stats.paths;
  r.renderSeconds = renderSeconds;
  return r;
}

}  // namespace lensfarm::test
