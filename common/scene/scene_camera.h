#pragma once
// The one registry of camera models (camera/camera.h): which camera a scene declares, and which
// one a render traces. A new model is one file pair in camera/ and one row in scene_camera.cpp.
#include <memory>

#include "common/camera/camera.h"
#include "common/scene/effects.h"
#include "common/scene/scene.h"

namespace lensfarm {

// The camera the scene declares at its render resolution: a real lens (camera.type "real_lens"),
// a pinhole (f_number infinity: "pinhole", or a thin lens with its aperture closed) or a thin lens.
// Throws InputError as the camera's constructor does.
std::unique_ptr<const Camera> declaredCamera(const Scene& scene);

// The camera a render traces: the declared one, except a thin lens whose blur the effect analysis
// found below half a cell at this resolution (effects.depthOfField false), which is traced as a
// pinhole: its rays need no lens sample (the effects a scene calls for, and no more).
std::unique_ptr<const Camera> renderCamera(std::unique_ptr<const Camera> declared, const EffectSet& effects);

}  // namespace lensfarm
