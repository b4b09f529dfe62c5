#pragma once
// The coplanar rule (docs/numerics.md, "Coplanar surfaces"): where a one-sided light lies in the
// plane of another surface and overlaps it (a lamp flush with a ceiling), the light wins.
//
// Two coplanar triangles are at the same distance along every ray, so which one Embree reports
// is decided by rounding: a path that scatters into the lamp sees the light on some rays and the
// ceiling on others, while a light sample always finds the lamp, and the estimators disagree
// (measured: 1.39x between naive and nee_mis in Coplanar.*). The loader therefore moves such a
// light towards the side it emits to by the least distance that Embree's tests resolve: twice
// both triangles' SpawnPlane margins (math/ray_offset.h) plus the rounding of the moved
// vertices, about 1e-6 of the light's size at the camera. Lights that overlap nothing in their
// plane are not touched (their images keep their bits), nor are non-planar emitting meshes or
// two-sided lights (two coplanar surfaces of which neither is a one-sided light: which one a ray
// sees is unspecified, the same in every run).
#include <cstddef>

#include "scene/scene.h"

namespace lensfarm {

// Applies the rule to every planar mesh whose triangles all emit from one side; returns how many
// lights were moved.
size_t bringFlushLightsForward(Scene& scene);

}  // namespace lensfarm
