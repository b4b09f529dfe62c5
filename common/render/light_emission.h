#pragma once
// Where the light tracer's particles start (render/light_tracer.h): from every kind of light, aimed
// at the delta surfaces it handles.
//
// The light tracer takes exactly the paths whose vertex next to the light lies on a delta surface
// (a mirror, smooth glass) of a material it handles; the path tracer keeps every other path. So a
// particle need only be able to reach those surfaces, all of which lie in one sphere, the target
// (c, R): particles from lights beyond the scene and from points are aimed at it, and those whose
// first hit is anything else are dropped, which loses nothing the light tracer owns.
//
// Each particle's weight beta makes E[beta] the flux it stands for (Veach 1997 §10.2, pbrt-v4's
// Light::SampleLe):
//  - An infinite light (the environment, a sun): a direction towards it, w ~ p(w) (its own light
//    sample, whatever the reference point), and a point x uniform on the disk of radius R through c
//    perpendicular to w. Every line along w through the sphere crosses that disk, so the rays
//    leaving x + 1.01 R w along -w cover every first hit in the sphere: beta = L(w) pi R^2 / p(w)
//    (a sun without diameter: E pi R^2). The particle starts inside the scene, so its line back to
//    the light must be checked: `reach` says how far (the light sample's shadow ray's rule,
//    SceneSphere::kReach), cast once its first hit counts.
//  - A light at a point q (point, spot): a direction uniform in the cone from q around the target
//    (half-angle asin(R / |c - q|); the whole sphere of directions when q lies within it), with
//    beta = I(w) / p(w). I(w) is read from the light's own sample at unit distance along w: the
//    radiance I(w) / r^2 a light sample brings with r = |q - (q + w)|, times r^2.
//  - An emitting triangle (render/light_tracer.cpp): a point y uniform by area, then a direction
//    uniform in the cone from y around the target, beta = L_e |cos| A / (P p(w)) (zero towards a
//    one-sided light's back); cosine-weighted where y lies within the target.
// Lights are chosen by the flux they send towards the target (fluxTowards); all units are the
// scene's radiance unit (light/light_source.h).
#include <cstdint>
#include <optional>
#include <vector>

#include "common/light/light_source.h"
#include "common/math/vec.h"

namespace lensfarm {

class RayCaster;
struct Scene;

struct LightEmission {
  Vec3 origin, direction;  // the particle's first ray
  Spectrum beta;           // its weight: flux over the densities that chose it (the light's choice excluded)
  // > 0: the origin is not on the light (an infinite light's disk): the particle's light reaches it
  // only if nothing lies within reach along -direction.
  float reach = 0.0f;
};

// A direction w uniform in the cone from q around `target`, or over the whole sphere of directions
// when q lies within it (cone false), and its solid-angle density.
struct AimedDirection {
  Vec3 w;
  double pdf;
  bool cone;
};
AimedDirection aimAt(const Vec3& q, Vec2 u, const SceneSphere& target);

// A particle of `light` (not an emitting triangle) aimed at `target`, from sample values uDirection
// and uPoint; nothing where it carries no light (a spot's dark side, a black environment texel).
std::optional<LightEmission> emitTowards(const LightSource& light, Vec2 uDirection, Vec2 uPoint,
                                         const SceneSphere& target, const SceneSphere& scene);

// The flux (luminance) `light`'s particles carry towards `target` on average: pi R^2 times an
// infinite light's irradiance, a point light's power times the fraction of directions aimed.
double fluxTowards(const LightSource& light, const SceneSphere& target, const SceneSphere& scene);

// The sphere holding every triangle of a material `aimedAt` says is a target (render space; every
// instance of a prototype using one, by its box); radius 0 where there is none.
SceneSphere targetSphere(const Scene& scene, const RayCaster& caster, const std::vector<uint8_t>& aimedAt);

}  // namespace lensfarm
