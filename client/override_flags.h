#pragma once
// The scene overrides that `render` and `submit` share: --spp, --resolution, --max-bounces,
// --seed, --integrator, --sampler, --russian-roulette, --target-error, --deadline, --ev; and the
// number checks every `lensfarm` flag uses.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "util/flag_checks.h"

#include "scene/frame_range.h"
#include "scene/render_overrides.h"

namespace lensfarm::cli {

struct OverrideFlags {
  std::optional<uint64_t> spp;
  std::optional<std::string> resolution;
  std::optional<int> maxBounces;
  std::optional<uint64_t> seed;
  std::optional<std::string> integrator;
  std::optional<std::string> sampler;
  std::optional<std::string> roulette;
  std::optional<double> targetError;
  std::optional<double> deadline;  // seconds
  std::optional<double> ev;
  // --camera NAME: a camera of the scene's models (glTF) instead of the scene's own; written into
  // the scene as "camera": NAME (makeLocalJob), so a farm renders the same.
  std::optional<std::string> camera;
  // --tile-size auto|off|N (docs/farm.md "Tiles and passes") and --frames RANGE (an animation:
  // "1-240", "1-240x2"; docs/scene-format.md "Frame ranges and output patterns").
  std::optional<std::string> tileSize;
  std::optional<std::string> frames;
  std::optional<std::string> adaptive;  // --adaptive on|off
  std::vector<std::string> aovs;  // --aov, repeatable, each a comma-separated list (docs/aovs.md)
  // --allow-path FOLDER, repeatable: a folder outside the scene's that its files may come from
  // (scene/asset_path.h); the job is read on the client, so this never reaches the farm.
  std::vector<std::string> allowPaths;

  void addTo(CLI::App* cmd);
  // Throws InputError naming the flag (e.g. a malformed --resolution).
  RenderOverrides toOverrides() const;
  // The frames asked for (nullopt: a still); InputError naming --frames.
  std::optional<FrameRange> frameRange() const;
  std::vector<std::filesystem::path> allowedFolders() const { return {allowPaths.begin(), allowPaths.end()}; }
};

// The flag checks (util/flag_checks.h), by their short names here.
using lensfarm::durationIn;
using lensfarm::nonNegativeNumber;
using lensfarm::numberIn;
using lensfarm::positiveNumber;
using lensfarm::wholeNumberIn;

}  // namespace lensfarm::cli
