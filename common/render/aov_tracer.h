#pragma once
// The geometric AOVs of a camera ray (albedo, normal, depth, ids; conventions in film/aov_layout.h
// and docs/aovs.md): a pass of its own beside the path tracer, so that the integrator's lane loops
// carry nothing for them and a scene without AOVs runs none of it.
#include "common/camera/thin_lens_camera.h"
#include "common/film/aov_layout.h"

namespace lensfarm {

class RenderScene;

// Adds the geometric AOVs of one sample, whose camera ray is `ray`, to `cell` (layout.channels
// doubles); `firstSample`: the pixel's sample 0, which carries the ids. Casts one ray, and one
// more per delta surface followed (at most kAovSpecularHops).
inline constexpr int kAovSpecularHops = 16;
void addGeometricAovs(const RenderScene& rs, const AovLayout& layout, const CameraRay& ray, bool firstSample,
                      double* cell);

// The same for lanes [0, count) of a packet of camera rays, their first hits found by one
// coherent 16-wide cast (RayCaster::intersect gives each lane the single-ray call's hit, so the
// sums are addGeometricAovs's bits); cells[k] is lane k's cell.
void addGeometricAovs(const RenderScene& rs, const AovLayout& layout, const CameraRayLanes& rays, int count,
                      const bool (&firstSample)[kPacketWidth], double* const (&cells)[kPacketWidth]);

}  // namespace lensfarm
