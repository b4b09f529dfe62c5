#pragma once
// Building a job from a scene file on the client's disk: the scene is loaded (and so validated)
// here first, and its assets are listed by content hash for upload. Every file is read once.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/farm/farm_types.h"
#include "common/scene/scene.h"

namespace lensfarm::cli {

struct LocalJob {
  Scene scene;  // loaded, with the overrides applied
  JobSpec spec;
  std::map<std::string, std::string> assetBytes;  // sha256 -> bytes
};

// Throws InputError naming the file and field if the scene (with the overrides) is invalid.
// `camera`: a model camera's name to render through instead of the scene's (--camera).
// `frames`: an animation's frames (JobSpec::frames); nullopt: a still. Files are read inside the
// scene's folder or `allowedFolders` only (scene/asset_path.h).
LocalJob makeLocalJob(const std::filesystem::path& sceneFile, const RenderOverrides& overrides,
                      const std::optional<std::string>& camera = std::nullopt,
                      const std::optional<FrameRange>& frames = std::nullopt,
                      const std::vector<std::filesystem::path>& allowedFolders = {});

}  // namespace lensfarm::cli
