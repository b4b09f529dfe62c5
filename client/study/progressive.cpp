#include "client/study/progressive.h"

#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <optional>
#include <thread>

#include "common/farm/job_layout.h"
#include "common/film/adaptive_allocation.h"
#include "common/film/image_io.h"
#include "common/film/sensor.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/util/hash.h"
#include "common/util/version.h"

namespace lensfarm::study {

namespace fs = std::filesystem;

Checkpoint renderProgressive(Scene scene, const ProgressiveRun& run,
                             const std::function<bool(const Checkpoint&)>& onCheckpoint) {
  RenderSettings& settings = scene.render;
  settings.samplesPerPixel = run.maxSamples;
  if (settings.samplesPerUnit == 0)
    settings.samplesPerUnit = settings.adaptive.enabled ? unitSize(settings) : uint32_t(run.firstCheckpoint);
  tbb::task_arena arena(int(run.threads ? run.threads : std::max(1u, std::thread::hardware_concurrency())));
  // Building the scene for rendering is timed with the render where it depends on the samples
  // (path guiding's training passes, render/path_guiding.h); elsewhere it is the load's.
  const auto built = std::chrono::steady_clock::now();
  std::optional<RenderScene> prepared;
  arena.execute([&] { prepared.emplace(scene); });
  const RenderScene& rs = *prepared;
  const double preparation =
      rs.guide() ? std::chrono::duration<double>(std::chrono::steady_clock::now() - built).count() : 0.0;
  const uint32_t perUnit = settings.samplesPerUnit;
  // An adaptive scene's passes and rounds (farm/job_layout.h); any other scene's layout is its passes.
  const JobLayout layout = JobLayout::of(settings, std::nullopt);
  const uint64_t samplesPerPixel = layout.samplesPerPixel, units = unitCount(samplesPerPixel, perUnit);
  // The scene's AOVs (render.aovs) are summed beside the beauty and developed as its layers.
  const AovLayout& aovs = rs.aovLayout();
  Sensor sensor(settings.width, settings.height, aovs.channels);
  ConvergenceTracker tracker(settings.width, settings.height);

  Checkpoint last;
  PathStats stats;
  double seconds = preparation;
  uint64_t next = run.firstCheckpoint;
  std::shared_ptr<const RoundAllocation> round;
  for (uint64_t unit = 0; unit < units; ++unit) {
    WorkUnit work = unitAt(unit, samplesPerPixel, perUnit);
    SensorBuffer buffer;
    const auto start = std::chrono::steady_clock::now();
    if (const int r = layout.roundOf(unit); r >= 0) {
      // A round is allocated from the film holding every unit before it, as the coordinator does
      // (coordinator/core/accumulator.cpp).
      if (unit == layout.roundStarts[size_t(r)]) {
        round = std::make_shared<const RoundAllocation>(allocateRound(sensor, tracker, layout.roundRequest(size_t(r))));
      }
      work.samples = round->mapOf(unit);
    }
    arena.execute([&] { renderUnit(rs, work, buffer, stats); });
    if (work.samples) {
      sensor.add(buffer, *work.samples);
      tracker.add(unit, buffer, *work.samples);
    } else {
      sensor.add(buffer);
      tracker.add(unit, buffer);
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const uint64_t spp = unit + 1 == units ? samplesPerPixel : work.firstSample + work.sampleCount;
    if (layout.adaptive() ? unit + 1 < units : !run.everyUnit && spp < next && spp < samplesPerPixel) continue;
    last.samplesPerPixel = spp;
    last.seconds = seconds;
    last.image = sensor.developImage(aovs);
    last.estimate = tracker.estimate(sensor);
    last.stats = stats;
    if (onCheckpoint && !onCheckpoint(last)) break;
    if (seconds >= run.budgetSeconds) break;
    while (next <= spp) next *= 2;
  }
  return last;
}

Image referenceImage(Scene scene, uint64_t samplesPerPixel, const fs::path& cacheDir, double* estimatedRelativeError,
                     unsigned threads) {
  RenderSettings& s = scene.render;
  s.integrator = IntegratorKind::kNeeMis;
  s.sampler = SamplerKind::kSobol;
  s.roulette = RouletteRule::kOff;
  s.samplesPerUnit = 16;
  // Its own random numbers: a reference sharing the measured renders' samples would be
  // correlated with them and hide part of their error.
  s.seed ^= 0x5eed5eed5eed5eedull;
  const std::string key = sha256Hex(scene.hash + "|" + std::to_string(s.width) + "x" + std::to_string(s.height) + "|B" +
                                    std::to_string(s.maxBounces) + "|" + std::to_string(samplesPerPixel) + "|seed" +
                                    std::to_string(s.seed) + "|" + kRendererVersion +
                                    (s.aovs.empty() ? "" : "|aovs " + aovListText(s.aovs)));
  const fs::path file = cacheDir / ("reference-" + key.substr(0, 16) + ".exr");
  if (fs::exists(file)) {
    ImageMetadata meta;
    Image image = readExr(file, &meta);
    if (estimatedRelativeError) *estimatedRelativeError = std::stod(meta.extra.at("estimatedRelativeError"));
    spdlog::info("reference {} ({}x{}, {} spp) from the cache", file.filename().string(), s.width, s.height,
                 samplesPerPixel);
    return image;
  }
  spdlog::info("rendering the reference: {}x{}, {} spp, B = {} (cached as {})", s.width, s.height, samplesPerPixel,
               s.maxBounces, file.string());
  ProgressiveRun run;
  run.firstCheckpoint = samplesPerPixel;
  run.maxSamples = samplesPerPixel;
  run.threads = threads;
  const Checkpoint done = renderProgressive(scene, run);
  ImageMetadata meta;
  meta.samplesPerPixel = done.samplesPerPixel;
  meta.totalSamples = done.samplesPerPixel * uint64_t(s.width) * uint64_t(s.height);
  meta.renderSeconds = done.seconds;
  meta.sceneHash = scene.hash;
  meta.rendererVersion = kRendererVersion;
  meta.extra["estimatedRelativeError"] = std::to_string(done.estimate.relativeRmse);
  fs::create_directories(cacheDir);
  writeExr(file, done.image, meta);
  if (estimatedRelativeError) *estimatedRelativeError = done.estimate.relativeRmse;
  return done.image;
}

}  // namespace lensfarm::study
