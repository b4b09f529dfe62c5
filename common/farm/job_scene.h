#pragma once
// The one way a job's scene is built from its spec: the client before it submits, the
// coordinator when a job is submitted and when it is restored, and a worker when it is leased a
// unit all call jobScene (or, for a scene already parsed, finishJobScene), so a scene one side
// accepts the others accept too, it is the same scene everywhere (its settings fix the job's
// units and bits), and each refusal reads the same wherever it is met.
#include <filesystem>
#include <optional>
#include <string>

#include "common/farm/farm_types.h"
#include "common/scene/scene_loader.h"

namespace lensfarm {

struct JobSceneOptions {
  // An animation's frame to load (scene_loader.h); unset: a still, or an animation's own frame.
  std::optional<double> frame;
  // The scene's name in messages (empty: the spec's sceneName), and where its overrides came
  // from (empty: the same; the client says "command line").
  std::filesystem::path shownAs;
  std::string overridesFrom;
};

// The spec's scene, its assets read through `readAsset`: parsed, the spec's overrides applied,
// and checked as finishJobScene does. InputError naming the scene, the field or the override.
Scene jobScene(const JobSpec& spec, const AssetReader& readAsset, const JobSceneOptions& options = {});

// What jobScene does after parsing, for a scene parsed another way (the client's models,
// scene_loader.h modelScene): the spec's overrides applied, the camera checked at the final
// resolution, and what a job cannot be refused: an animation (spec.frames) that stops on an
// error target or a time limit, or samples adaptively.
void finishJobScene(Scene& scene, const JobSpec& spec, const JobSceneOptions& options = {});

}  // namespace lensfarm
