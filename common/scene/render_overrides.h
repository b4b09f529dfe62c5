#pragma once
// Command-line (or job-request) overrides of a scene's render settings. `lensfarm render` and
// `lensfarm submit` accept the same ones, and a worker applies a job's overrides exactly as the
// coordinator did, so every process renders the same job.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace lensfarm {

struct RenderOverrides {
  std::optional<uint64_t> samplesPerPixel;
  std::optional<int> width, height;
  std::optional<int> maxBounces;
  std::optional<uint64_t> seed;
  std::optional<IntegratorKind> integrator;
  std::optional<SamplerKind> sampler;
  std::optional<bool> russianRoulette;
  std::optional<double> targetError;       // relative RMSE; samplesPerPixel becomes a cap
  std::optional<double> timeLimitSeconds;  // the deadline, from submission
  std::optional<double> ev;
  // RenderSettings::tileSize: kTilesAuto, kTilesOff or an edge in pixels (at least 1).
  std::optional<int> tileSize;
  std::optional<AovSet> aovs;  // replaces render.aovs (docs/aovs.md)
  std::optional<bool> adaptive;  // RenderSettings::adaptive.enabled (its other settings stay the scene's)
};

// Parses AOV lists ("albedo,normal", each a --aov value) into `o`; throws InputError naming `flag`.
void parseAovs(const std::vector<std::string>& lists, RenderOverrides& o, const std::string& flag = "--aov");

// Parses "auto", "off" or a tile edge in pixels (at least 1) into `o`; throws InputError naming
// `flag` ("--tile-size 0: ...").
void parseTileSize(const std::string& text, RenderOverrides& o, const std::string& flag = "--tile-size");

// Parses "WIDTHxHEIGHT" into `o`; throws InputError naming `flag`.
void parseResolution(const std::string& text, RenderOverrides& o, const std::string& flag = "--resolution");

// Applies the overrides and checks the result against the loader's limits; throws InputError
// naming `where` and the setting.
void applyOverrides(const RenderOverrides& o, RenderSettings& settings, const std::string& where);

}  // namespace lensfarm
