#include "override_flags.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <memory>

#include "scene/scene_loader.h"
#include "util/error.h"

namespace lensfarm::cli {

void OverrideFlags::addTo(CLI::App* cmd) {
  cmd->add_option("--camera", camera, "A camera of the scene's glTF models, by name (instead of the scene's camera)");
  cmd->add_option("--spp", spp, "Samples per pixel (overrides the scene)")
      ->check(wholeNumberIn(1, kMaxSamplesPerPixel));
  cmd->add_option("--resolution", resolution, "Image size WIDTHxHEIGHT (overrides the scene)");
  cmd->add_option("--max-bounces", maxBounces, "Bounce limit B (overrides the scene)")
      ->check(wholeNumberIn(0, kMaxBounces));
  cmd->add_option("--seed", seed, "Random seed (overrides the scene)")->check(wholeNumberIn(0, UINT64_MAX));
  cmd->add_option("--integrator", integrator, "nee_mis, nee or naive (overrides the scene)")
      ->check(CLI::IsMember({"nee_mis", "nee", "naive"}));
  cmd->add_option("--sampler", sampler, "sobol, stratified or independent (overrides the scene)")
      ->check(CLI::IsMember({"sobol", "stratified", "independent"}));
  cmd->add_option("--russian-roulette", roulette, "on (the scene's rule, or throughput where it has none) or off (overrides the scene)")->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--target-error", targetError,
                  "Stop when the estimated relative RMSE of the image falls to this (e.g. 0.01); --spp becomes a cap")
      ->check(numberIn(1e-6, 0.999));
  cmd->add_option("--deadline", deadline,
                  "Stop this long after submission (e.g. 90s, 10m, 2h), with a whole number of units")
      ->transform(durationIn(1e-3, 1e9));
  cmd->add_option("--tile-size", tileSize,
                  "How the frame is cut into units: auto (default), off (every unit covers the whole frame) or a tile "
                  "edge in pixels; never changes the image");
  cmd->add_option("--frames", frames,
                  "Render an animation's frames: 7, 1-240 or 1-240x2 (every 2nd); outputs need #### for the number");
  cmd->add_option("--aov", aovs,
                  "Outputs beside the beauty, written as EXR layers: albedo, normal, depth, variance, samples, "
                  "object_id, material_id (comma-separated or repeated; replaces the scene's render.aovs)");
  cmd->add_option("--adaptive", adaptive,
                  "on: spend a quarter of the samples uniformly, then the rest where the estimated error is "
                  "(docs/accuracy.md \"Adaptive sampling\"; --spp becomes the mean); off: uniform (overrides the scene)")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--ev", ev, "Exposure compensation in stops for PNG images (overrides the scene)")
      ->check(numberIn(-kMaxExposureEv, kMaxExposureEv, "stops"));
  cmd->add_option("--allow-path", allowPaths,
                  "A folder outside the scene's that the scene and its models may read files from (repeatable); "
                  "by default every file must lie inside the scene's folder (LENSFARM_ALLOW_PATH: more, colon-separated)")
      ->check(CLI::ExistingDirectory);
}

RenderOverrides OverrideFlags::toOverrides() const {
  RenderOverrides o;
  if (resolution) parseResolution(*resolution, o);
  o.samplesPerPixel = spp;
  o.maxBounces = maxBounces;
  o.seed = seed;
  if (integrator) parseIntegratorName(*integrator, o.integrator.emplace());
  if (sampler) parseSamplerName(*sampler, o.sampler.emplace());
  if (roulette) o.russianRoulette = *roulette == "on";
  if (targetError) {
    o.targetError = *targetError;
    if (!spp) o.samplesPerPixel = kMaxSamplesPerPixel;  // the target alone: no sample cap
  }
  if (deadline) o.timeLimitSeconds = *deadline;
  if (deadline && !spp && !targetError) o.samplesPerPixel = kMaxSamplesPerPixel;  // until the deadline
  o.ev = ev;
  if (tileSize) parseTileSize(*tileSize, o);
  if (!aovs.empty()) parseAovs(aovs, o);
  if (adaptive) o.adaptive = *adaptive == "on";
  return o;
}

std::optional<FrameRange> OverrideFlags::frameRange() const {
  if (!frames) return std::nullopt;
  return parseFrameRange(*frames, "--frames");
}

}  // namespace lensfarm::cli
