#pragma once
// The flags that `render` and `submit` share: one per render override (the rows of
// scene/render_overrides.h overrideTable()), --camera, --frames and --allow-path; and the number
// checks every `lensfarm` flag uses.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/util/flag_checks.h"

#include "common/scene/frame_range.h"
#include "common/scene/render_overrides.h"

namespace lensfarm::cli {

struct OverrideFlags {
  // The text of each render override's flag, by row name (scene/render_overrides.h overrideTable()):
  // one text, or for a repeatable flag (--aov) every one given.
  std::map<std::string, std::vector<std::string>> texts;
  // --camera NAME: a camera of the scene's models (glTF) instead of the scene's own; written into
  // the scene as "camera": NAME (makeLocalJob), so a farm renders the same.
  std::optional<std::string> camera;
  // --frames RANGE (an animation: "1-240", "1-240x2"; docs/scene-format.md "Frame ranges and
  // output patterns").
  std::optional<std::string> frames;
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
