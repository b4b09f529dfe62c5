#pragma once
// Light tracing (Veach 1997 ch. 10: bidirectional strategy t = 1; pbrt-v4
// ConnectBDPT), beside the path tracer, for the caustics next-event estimation
// cannot sample: light -> mirror or glass -> diffuse surface -> camera
// (cornell-seed's floor lit through its rippled mirror, glass-metal-sky's sun
// through the glass ball, any delta light's caustic).
//
// Particles leave the emitting triangles the light sampler samples
// (render/light_sampler.h), when RenderScene::lightTracesTriangles: a triangle
// chosen by power, a uniform point on it, a cosine-weighted direction (either
// face of a two-sided light with probability 1/2); and every other light, aimed
// at the delta surfaces the tracer handles (render/light_emission.h). Their
// weight beta is flux: after k scatterings,
//     E[sum over particle vertices y of beta(y) g(y, w_l)] = int_A int L_i(y,
//     w_l) |cos_l| g dw_l dA,
// with beta_0 = L_e pi A / P(triangle) (x2 two-sided) and, at each scattering,
// the adjoint BSDF's weight f(w_n, w_l) |cos_n| / p(w_n | w_l) (w_l towards the
// light, w_n the sampled next direction). Lambertian: the albedo (f is
// symmetric). Mirror and rippled mirror: the sample's weight times |cos_n| /
// |cos_l| (reflection about a normal m sampled with density D(m): f(wo, wi)
// |cos_i| = R D(m) / (4 |wo.m|) is not symmetric, its sampling density is; the
// rippled mirror's fold of grazing reflections back above the surface breaks
// that symmetry within about 2 ripple angles of grazing, where this weight is
// approximate).
//
// Camera connection. A pixel is (camera/thin_lens_camera.h,
// render/unit_renderer.cpp)
//     I_ij = w_ap E_r[ (1 / A_cell) int_cell L(r, w(s, r)) ds ],
// with r the lens point (Aperture::sample, the density p(r) camera rays use; r
// = 0 for a pinhole or a lens traced as one), s uniform in the cell, w_ap the
// aperture's mean transmission, and no cos^4 falloff. For a fixed r the thin
// lens maps s to the direction w leaving r: its unit-axial form is n2 = (r - s)
// / S2 - r / f, so ds = S2^2 d(n2) = S2^2 dw / cos^3(theta), theta the angle
// between w and the axis; and dw = |cos_y| dA_y / d^2 towards a surface point y
// at distance d. So
//     I_ij = w_ap E_r[ int_A (S2^2 / (A_cell cos^3 theta)) (|cos_y| / d^2) V(r,
//     y) L(y -> r) 1_ij(s) dA_y ],
// and with L(y -> r) = int f(w_c, w_l) L_i(y, w_l) |cos_l| dw_l, one particle
// vertex y (non-delta) with one lens point r sampled as camera rays sample it
// contributes to cell (i, j) of s(r, y)
//     C = beta f(w_c, w_l) |cos_y| / d^2 * W,   W = w_ap S2^2 / (A_cell cos^3
//     theta)        (LT)
// where W is the camera's importance for this renderer's pixel definition
// (pbrt's perspective camera has 1 / (A cos^4 theta) because its measurement
// carries the lens's cos theta; ours does not). A unit of n samples per pixel
// traces N = ceil(ratio n W H) particles and adds n C / N to the cell's sums:
// the sensor divides by n, leaving the N-particle mean. V is a camera ray from
// r to y (what a camera ray sees: geometry hidden from the camera is not seen).
// The camera computes r, the cell and W (camera/camera.h, Camera::connect); a
// camera without a closed-form importance (a real lens) is never light-traced.
//
// Combination (Veach 1997 §10.2: the weights need only sum to 1 per path):
// binary. The light tracer takes exactly the paths whose camera-side first
// vertex is non-delta and whose vertex next to the light is delta, every vertex
// of a material it handles (scene/effects.h, lightTraceable) and the light one
// that emits particles; the path tracer drops exactly those (the emitter hit or
// the ray leaving the scene after a delta vertex; render/path_vertex.h,
// PathState::lightTraced) and keeps the rest. Smooth glass: the sample's weight
// times eta^2 (flux, not radiance, crosses the boundary). Both honour the bounce limit B, the counting of mirror
// bounces and pathSegmentLimit(B) alike.
//
// Determinism: a particle's numbers are counter-based (render/sampler.h,
// dims::kEmitDirection, dims::kLensPoint), keyed by the unit's first sample and
// frame and the particle's index; a unit's particles are cut into chunks of
// kChunkParticles, whatever the thread count, each chunk records its splats,
// and the splats are added in chunk order: the same bits for any thread or
// worker count.
#include <atomic>

#include "common/film/sensor.h"
#include "common/render/integrator.h"
#include "common/render/render_scene.h"

namespace lensfarm {

struct WorkUnit;

inline constexpr uint64_t kChunkParticles = 4096;

// The number of light paths a unit of `samples` samples per pixel traces
// (RenderSettings:: lightTracingRatio per camera path).
uint64_t lightPathsOf(const RenderScene& rs, uint32_t samples);

// Traces the unit's light paths and adds their contributions to `out` (a
// whole-frame buffer holding the unit's camera paths). Adds the rays cast to
// `stats`. False if `cancel` was raised.
bool traceLightPaths(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                     const std::atomic<bool>* cancel);

}  // namespace lensfarm
