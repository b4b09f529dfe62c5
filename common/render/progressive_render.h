#pragma once
// The local progressive render (seed §4.7.2): units are traced one after another on all cores
// and added to the sensor in unit order; between units the caller may draw a snapshot.
// It stops at the sample target, at the time limit, or when `cancel` is raised (the unit in
// flight is then discarded, so the sensor always holds whole units).
#include <atomic>
#include <functional>

#include "film/sensor.h"
#include "render/integrator.h"
#include "render/render_scene.h"

namespace lensfarm {

struct RenderProgress {
  uint64_t samplesPerPixelDone = 0;
  uint64_t samplesPerPixelTarget = 0;
  double elapsedSeconds = 0.0;
  double timeLimitSeconds = 0.0;  // 0: none
  PathStats stats;

  double raysPerSecond() const { return elapsedSeconds > 0.0 ? double(stats.rays) / elapsedSeconds : 0.0; }
  double fractionDone() const;
  double remainingSeconds() const;  // estimate
};

struct ProgressiveOptions {
  uint64_t samplesPerPixel = 0;   // target
  double timeLimitSeconds = 0.0;  // 0: none
  double snapshotEverySeconds = 0.0;  // 0: no snapshots while rendering
  std::function<void(const Sensor&, const RenderProgress&)> onSnapshot;
  std::function<void(const RenderProgress&)> onProgress;  // after every unit
  const std::atomic<bool>* cancel = nullptr;
};

struct RenderOutcome {
  RenderProgress progress;
  bool interrupted = false;
};

RenderOutcome renderProgressive(const RenderScene& rs, Sensor& sensor, const ProgressiveOptions& options);

}  // namespace lensfarm
