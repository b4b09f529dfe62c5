#pragma once
// The volume path tracer: camera paths through participating media (docs/media.md), for scenes
// whose effect analysis says a path can be in one (EffectSet::media). Every other scene is traced
// by the surface tracers (render/integrator.h), which contain no medium code: a scene without a
// medium pays nothing for media.
//
// The volume rendering equation (PBR 4th ed. eq. 14.3) along each ray segment [0, t_hit) in a
// medium: L(o) = int_0^t_hit T(t) sigma_s(t) int p L_i dw dt + T(t_hit) L(surface). Each segment
// samples a free-flight distance (Medium::sampleFreeFlight): a scattering event inside the
// segment becomes a medium vertex; a pass reaches the surface with the transmittance folded into
// the throughput.
//
// At a medium vertex: one light sample (next-event estimation) weighted by the phase function,
// its shadow ray attenuated by the media it crosses (never just blocked; ratio tracking in a
// grid), then a phase-function sample for the next direction; with NEE + MIS the light sample and
// a scattered ray that reaches a light are combined by the power heuristic on their directional
// densities (weights that sum to 1 for every path keep MIS unbiased whatever densities they use).
// Surface vertices are shaded exactly as the surface tracers shade them (render/path_vertex.h).
//
// Which medium a ray is in: the scene's `medium` (or none) at the camera; crossing a surface
// whose material has an interior medium against its normal enters that medium, crossing it along
// the normal returns to the scene's medium (media do not nest). A material of type `interface`
// scatters nothing: rays and shadow rays cross it unchanged (an index-matched boundary).
//
// Bounce limits: B (render.max_bounces) counts surface bounces as everywhere; scattering events
// in media count separately, up to render.max_medium_bounces. A path ends at whichever limit it
// reaches first; with NEE, the vertex at a limit takes its light sample with weight 1 and casts
// no scattered ray (render/integrator.cpp, isLastBounce), so no in-scattering follows it.
//
// Determinism: the sampler's dimensions drive every fixed-count choice (light sample, phase or
// BSDF direction, roulette); tracking, whose count of random numbers varies, draws from a
// MediumRng keyed by the sample's stream and the segment (medium/medium.h). A path's value thus
// depends on its pixel and sample only.
#include "common/render/integrator.h"

namespace lensfarm {

template <bool kNee>
Spectrum traceVolumePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats);

}  // namespace lensfarm
