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
// vertices, about 1e-6 of the light's size at the camera. A light here is the one-sided
// emitting triangles of one mesh that share a plane (a light quad, or an OBJ group of an
// emissive material next to the ceiling's group) and whose vertices no other triangle uses.
// Lights that overlap nothing in their plane are not touched (their images keep their bits),
// nor are two-sided lights or lights whose vertices other triangles share (two coplanar
// surfaces of which neither is such a light: which one a ray sees is unspecified, the same in
// every run).
#include <cstddef>

#include "common/scene/scene.h"

namespace lensfarm {

// Applies the rule; returns how many lights were moved.
size_t bringFlushLightsForward(Scene& scene);

}  // namespace lensfarm
