#include "render/progressive_render.h"

#include <algorithm>
#include <chrono>

#include "render/unit_renderer.h"

namespace lensfarm {

double RenderProgress::fractionDone() const {
  double f = samplesPerPixelTarget ? double(samplesPerPixelDone) / double(samplesPerPixelTarget) : 0.0;
  if (timeLimitSeconds > 0.0) f = std::max(f, elapsedSeconds / timeLimitSeconds);
  return std::min(f, 1.0);
}

double RenderProgress::remainingSeconds() const {
  const double f = fractionDone();
  return f > 0.0 ? elapsedSeconds * (1.0 - f) / f : 0.0;
}

RenderOutcome renderProgressive(const RenderScene& rs, Sensor& sensor, const ProgressiveOptions& options) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  const uint32_t perUnit = unitSize(rs.settings());

  RenderOutcome outcome;
  RenderProgress& progress = outcome.progress;
  progress.samplesPerPixelTarget = options.samplesPerPixel;
  progress.timeLimitSeconds = options.timeLimitSeconds;
  double lastSnapshot = 0.0;
  SensorBuffer buffer;

  const uint64_t units = unitCount(options.samplesPerPixel, perUnit);
  for (uint64_t k = 0; k < units; ++k) {
    if (options.timeLimitSeconds > 0.0 && seconds() >= options.timeLimitSeconds) break;
    PathStats unitStats;
    if (!renderUnit(rs, unitAt(k, options.samplesPerPixel, perUnit), buffer, unitStats, options.cancel)) {
      outcome.interrupted = true;
      break;
    }
    sensor.add(buffer);
    progress.stats += unitStats;
    progress.samplesPerPixelDone += buffer.samples.empty() ? 0 : buffer.samples[0];
    progress.elapsedSeconds = seconds();
    if (options.onProgress) options.onProgress(progress);
    if (options.snapshotEverySeconds > 0.0 && options.onSnapshot &&
        progress.elapsedSeconds - lastSnapshot >= options.snapshotEverySeconds && k + 1 < units) {
      options.onSnapshot(sensor, progress);
      lastSnapshot = progress.elapsedSeconds;
    }
  }
  progress.elapsedSeconds = seconds();
  return outcome;
}

}  // namespace lensfarm
