#pragma once
// Path tracing from the camera (2013 report §4.3: "the best direction of shooting photons is from the
// camera"), with a bounce limit B (§4.5) and RGB colour mixing (§4.5.1, eq. 2).
//
// Bounce counting. A path of k bounces reflects k times between the lens and the light; B = 1 is
// direct light only (the report's Fig. 8a). Mirror reflections do not count (the report's §4.5) unless the scene
// says `mirror_bounces_count`; a path still ends after pathSegmentLimit(B) segments so two
// facing mirrors cannot loop forever.
//
// Estimators:
//  - naive (the report's): a path contributes only if a scattered ray happens to hit a light, except
//    for delta lights (point, spot, a sun without diameter), which no ray can hit: those alone are
//    light-sampled at each diffuse vertex (weight 1; render/light_sampler.h);
//  - nee: at each diffuse vertex one light sample (next-event estimation), weight 1; a scattered
//    ray that reaches a light the samples can produce counts 0;
//  - nee_mis: one light sample plus the scattered ray, combined with the power heuristic (Veach
//    1997). All are unbiased for the same B.
// "Reaching a light" is hitting an emitting triangle or leaving the scene towards the
// environment or a sun with an angular diameter (addEscapedLight); after the camera or a delta
// lobe either counts with weight 1. A ray that leaves the scene ends its path.
//
// Two forms of the same tracer:
//  - tracePath traces one camera path, one ray at a time: the readable reference, whose vertex
//    logic is shadeVertex (integrator.cpp);
//  - tracePacket traces up to kPacketWidth paths at once (docs/performance.md): each
//    segment of the packet's live paths is one 16-wide Embree intersection call and at most one
//    16-wide occlusion call for their shadow rays; paths that end leave the packet (their lane is
//    switched off). The paths' state, the hits and every step of a Lambertian or glossy vertex
//    (the decisions, the light sample, the shadow ray, the scattered direction) are arrays over
//    the lanes and loops over them, which the compiler vectorises (math/lanes.h). Glossy: a
//    material whose model a PrincipledModel record holds (glTF's metallic-roughness without
//    textures, material/principled_model.h), its shading normal taken per point where its mesh
//    has vertex normals. Only lanes that meet another model (mirrors, glass, conductors,
//    textures) or an emitter, leave the scene towards a light beyond it (only in a scene that has
//    one) or choose a light that is not a triangle go one at a time, through shadeVertex /
//    addEmittedLight / addEscapedLight / LightSampler::sample. The lane loops evaluate
//    the same shared formulas (the warps, offsets, Lambertian lobe, principled model, light
//    sample, MIS weight) in the same order, so a lane computes exactly what tracePath computes for its sample and its
//    radiance depends on its own sample only: never on which samples share its packet, on the
//    thread, the worker or the machine's vector width (tests/render/packet_integrator_test.cpp).

#include <cstdint>

#include "common/camera/thin_lens_camera.h"
#include "common/film/path_stats.h"
#include "common/math/vec.h"
#include "common/render/render_scene.h"
#include "common/render/sampler.h"
#include "common/scene/path_limits.h"

namespace lensfarm {

// Radiance arriving along the camera ray of one sample, with next-event estimation and specular
// materials compiled in or out (scene/effects.h): a specialisation has no branch for an effect
// the scene does not need, and gives the general path's bits when the effect is absent.
template <bool kNee, bool kGeneral>
Spectrum tracePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats);

class GuidingField;
struct GuidingRecorder;
// A training path of path guiding (render/path_guiding.h): tracePath's path for `rs`'s estimator
// with every material's code compiled in, guided by `guide` (null: unguided), its guided vertices
// recorded by `recorder` (cleared first; GuidingRecorder::finish turns them into records).
Spectrum traceTrainingPath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng,
                           const GuidingField* guide, GuidingRecorder& recorder, PathStats& stats);

// The camera paths of one packet: lane k traces its camera ray with the sample values rng[k], for
// k < count (count <= kPacketWidth).
struct PathPacket {
  int count = 0;
  CameraRayLanes cameraRays;  // lane k's: cameraRays.ray(k)
  SampleStream rng[kPacketWidth];
};

// Each lane's radiance into radiance[0, count): tracePath<kNee, kGeneral> for every lane.
template <bool kNee, bool kGeneral>
void tracePacket(const RenderScene& rs, const PathPacket& packet, Spectrum (&radiance)[kPacketWidth], PathStats& stats);

}  // namespace lensfarm
