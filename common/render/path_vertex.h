#pragma once
// What a camera path does at a surface, shared by the surface path tracer (render/integrator.cpp)
// and the volume path tracer (render/volume_integrator.cpp): the path's state, light reached by a
// ray, Russian roulette, and shadeVertex, which shades one surface vertex (emission, the bounce
// limit, a light sample as a shadow query, the scattered direction). Internal to the tracers.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "common/math/ray_offset.h"
#include "common/math/sampling.h"
#include "common/medium/equiangular.h"
#include "common/render/integrator.h"
#include "common/render/path_guiding.h"
#include "common/render/shading_point.h"

namespace lensfarm::path_vertex {

// Shadow rays stop this fraction short of the light point (itself offset off the light).
constexpr float kShadowEpsilon = 1e-4f;

// A medium vertex whose direct light equiangular sampling also estimates (render/volume_integrator.cpp):
// its ray segment [0, tMax) from `origin` along `direction`, its distance t on it and the
// free-flight density there. A triangle light its scattered ray reaches is weighed against both
// light strategies: the light sample's solid-angle density is scaled by
// sqrt(1 + (p_equiangular(t | x) / p_free-flight(t))^2), x the point reached (the power heuristic
// over three strategies, volume_integrator.cpp).
// r = p_e / p_d, the equiangular density over the free-flight one at a point of a segment; infinite
// where free flight cannot reach it (its density underflowed) and equiangular sampling can.
inline double equiangularRatio(double pe, double pd) {
  if (!(pd > 0.0)) return pe > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  return pe / pd;
}

struct MediumVertexMis {
  Vec3 origin, direction;
  float tMax, t, freeFlightPdf;

  // r for light point x at this vertex.
  double ratio(const Vec3& x) const {
    return equiangularRatio(equiangularPdf(equiangularSegment(origin, direction, 0.0f, tMax, x), t), freeFlightPdf);
  }
  // The density to weigh a phase sample reaching light point x against, both light strategies
  // together: sqrt(b^2 + c^2) over p_d, b = `lightPdf` (the light sample's), c = r `byPower` (the
  // equiangular strategy's, whose light point is chosen by power: LightSampler::HitPdf).
  float lightPdf(const Vec3& x, float lightPdf, float byPower) const {
    const double r = ratio(x);
    if (lightPdf == byPower)
      return std::isinf(r) ? std::numeric_limits<float>::infinity() : lightPdf * float(std::sqrt(1.0 + r * r));
    if (std::isinf(r)) return byPower > 0.0f ? std::numeric_limits<float>::infinity() : lightPdf;
    const double c = r * byPower;
    return float(std::sqrt(double(lightPdf) * lightPdf + c * c));
  }
};

// One camera path between two ray casts.
struct PathState {
  Spectrum radiance{0.0f};
  Spectrum throughput{1.0f};
  Vec3 origin{0.0f}, direction{0.0f};  // the next ray to cast
  // The vertex the last scattered ray left: the point its light sample was taken from, where a
  // light tree's choice of the light that ray reaches is weighed (render/light_tree.h). (The
  // packet form keeps it only while a tree chooses lights.)
  Vec3 vertex{0.0f};
  int bounces = 0;           // counted bounces so far (toward B)
  bool lastSpecular = true;  // the camera ray behaves like a specular one: no MIS for it
  float lastPdf = 0.0f;      // solid-angle pdf of the last scattered direction
  float etaScale = 1.0f;     // product of eta^2 over the refractions so far (Russian roulette)
  bool hitLight = false;
  // The path so far is one the light tracer also samples, once it reaches a light through a delta
  // vertex (render/light_tracer.h): its first vertex scattered by a non-delta lobe and every vertex
  // is of a material the light tracer handles. Only set while light tracing is on.
  bool lightTraced = false;
  // Set by the volume tracer after a medium vertex whose direct light two strategies sample.
  const MediumVertexMis* mediumVertex = nullptr;
  // Path guiding (render/path_guiding.h): the field that guides the path's diffuse vertices (null:
  // none), and while training, what records them.
  const GuidingField* guide = nullptr;
  GuidingRecorder* recorder = nullptr;

  explicit PathState(const CameraRay& ray) : origin(ray.origin), direction(ray.direction) {}
  PathState() = default;
};

// The shadow ray of a vertex's light sample and what it adds if nothing blocks it.
struct ShadowQuery {
  Vec3 from, direction;  // from the vertex (offset off its surface) ...
  float tFar;            // ... to from + tFar direction
  Spectrum contribution;
};

// The shadow ray from a vertex towards the light point, d = to - from (both ends offset off their
// surfaces). To an emitting triangle (reach 0) it is the segment itself, stopping kShadowEpsilon
// short, as it always was. To any other light (LightSample::reach > 0) it is cast along the unit
// direction and runs reach times the distance (less kShadowEpsilon): Embree's triangle test
// multiplies the direction by products of coordinates, which a direction as long as the scene
// overflows in float when the scene is larger than about 1e12 (docs/numerics.md).
inline void unitShadowRay(const Vec3& d, float reach, Vec3& direction, float& tFar) {
  const float length = glm::length(d);
  direction = d / length;
  tFar = reach * length * (1.0f - kShadowEpsilon);
}

struct VertexOutcome {
  bool castShadow = false;  // `shadow` holds a light sample whose ray must be tested
  bool continues = false;   // `path` holds the next ray to cast
  bool straight = false;    // it went straight through a thin wall: no vertex (kThinWalls)
};

// The weight of light that the camera ray or a scattered ray reaches (an emitter it hits, or a
// light beyond the scene when it leaves), given lightPdf(), the density with which a light sample
// would have produced it: 1 after the camera or a delta lobe, and for a light no light sample can
// produce (lightPdf() 0: with the naive estimator every light but the delta ones, which rays never
// reach); else the power heuristic after a non-delta vertex (NEE + MIS) or 0 there (NEE alone,
// whose light samples count it instead).
template <bool kNee, typename LightPdf>
inline float reachedLightWeight(const RenderScene& rs, const PathState& path, LightPdf lightPdf) {
  if (!kNee || path.lastSpecular) return 1.0f;
  const float pdf = lightPdf();
  if (!(pdf > 0.0f)) return 1.0f;
  return rs.settings().integrator == IntegratorKind::kNeeMis ? powerHeuristic(path.lastPdf, pdf) : 0.0f;
}

// Light reached by the camera ray or a scattered ray: emission reaching the sensor, weighted as
// reachedLightWeight says.
template <bool kNee>
inline void addEmittedLight(const RenderScene& rs, const SurfaceHit& hit, const Material& material, PathState& path) {
  if (!material.isEmissive()) return;
  Spectrum le = rs.lights().emitted(hit.triangle, path.direction);
  if (isBlack(le)) return;
  if (const MaterialTextures* t = material.textures(); t && t->emissive) {
    // An emissive texture: its value at the hit (light samples take it at their point,
    // render/light_sampler.h, and weigh against this hit by the triangle's density).
    const Vec3 wo = -path.direction;
    const bool front = glm::dot(hit.n, wo) >= 0.0f;
    const ShadingPoint sp = shadingPoint(rs, hit, wo, front ? hit.n : -hit.n, front);
    le = le * glm::max(Spectrum(t->emissive.sample(sp.uv, sp.footprint)), Spectrum(0.0f));
    if (isBlack(le)) return;
  }
  path.hitLight = true;
  // Binary MIS with the light tracer (render/light_tracer.h): a light reached through a delta
  // vertex after a diffuse first vertex is the light tracer's to count, where it emits.
  if (path.lightTraced && path.lastSpecular && rs.lightTracesTriangles() && rs.lights().samplesTriangle(hit.triangle))
    return;
  const float weight = reachedLightWeight<kNee>(rs, path, [&] {
    const LightSampler::HitPdf pdf = rs.lights().pdfs(hit.triangle, path.vertex, hit.t, path.direction);
    return path.mediumVertex && pdf.byPower > 0.0f ? path.mediumVertex->lightPdf(hit.p, pdf.pdf, pdf.byPower) : pdf.pdf;
  });
  path.radiance += path.throughput * le * weight;
}

// The camera ray or a scattered ray left the scene: the radiance of the lights beyond it that it
// reaches (the environment, a sun with an angular diameter), each weighted as an emitter is. Only
// called where the scene has such lights (RenderScene::hasEscapeLights); the path ends.
template <bool kNee>
inline void addEscapedLight(const RenderScene& rs, PathState& path) {
  // Binary MIS with the light tracer: every light beyond the scene emits light paths (render/
  // light_emission.h), which count what arrives through a delta vertex after a diffuse first one.
  if (path.lightTraced && path.lastSpecular) return;
  for (const LightSampler::EscapeLight& e : rs.lights().escapeLights()) {
    const Spectrum le = e.light->escaped(path.direction);
    if (isBlack(le)) continue;
    path.hitLight = true;
    const float weight = reachedLightWeight<kNee>(rs, path, [&] { return LightSampler::pdf(e, path.direction); });
    path.radiance += path.throughput * le * weight;
  }
}

// After the vertex that `segment`'s ray hit (of material `material`) has scattered: whether the
// path is still one the light tracer samples (PathState::lightTraced).
inline bool stillLightTraced(const RenderScene& rs, int segment, uint32_t material, bool traced, bool lastSpecular) {
  return rs.lightTraced(material) && (segment == 0 ? !lastSpecular : traced);
}

// The last counted bounce: the next vertex would end the path at the bounce limit, so the
// scattered ray could only bring back emission, light the light sample already estimates.
// There the light sample alone (weight 1, a valid MIS weighting of one strategy) carries the
// direct light and the scattered ray is not cast: about one ray in six fewer at B = 3, same
// expectation (Furnace and Estimators tests). Not after a mirror could follow: a mirror that
// does not count would carry the path on to the light (a caustic light sampling cannot see). Nor
// with the naive estimator, whose light samples (of delta lights only) leave the other lights to
// the scattered ray.
inline bool lastBounceCanEndPaths(const RenderScene& rs) {
  return (!rs.mirrorsReachable() || rs.settings().mirrorBouncesCount) &&
         rs.settings().integrator != IntegratorKind::kNaive;
}
inline bool isLastBounce(const RenderScene& rs, int bounces) {
  return bounces + 1 >= rs.settings().maxBounces && lastBounceCanEndPaths(rs);
}

// Russian roulette (render.russian_roulette, scene.h RouletteRule): once a path has made more
// than rouletteMinBounces counted bounces, it survives with probability q and carries 1/q more,
// so the estimate stays unbiased (E[1{u < q} / q] = 1) while dim paths stop early. `max`: q =
// min(1, max throughput component). `throughput` (Cycles' path_state_continuation_probability):
// q = min(1, sqrt(max component of throughput x etaScale)), etaScale undoing the 1/eta^2 radiance
// scaling of the refractions so far (pbrt-v4's PathIntegrator: a path inside glass carries
// 1/eta^2 that leaving the glass gives back, and is not dim for it); the square root ends paths
// later than the max rule does. Nor does `throughput` gamble the ray after the last counted bounce
// (bounces = B), which can only gather emission (no light sample follows it): ending it saves one
// ray of the path and drops what that ray alone finds, a caustic where mirrors do not count (on
// cornell-seed, B = 2, roulette there cost 9 % of the error per second; docs/performance.md).
// The decision draws dims::kRoulette of the vertex: counter-based, the same for any thread
// count. False where the path ends.
inline bool survivesRoulette(const RenderSettings& settings, const SampleStream& rng, uint32_t base, int bounces,
                             float etaScale, Spectrum& throughput) {
  if (settings.roulette == RouletteRule::kOff || bounces <= settings.rouletteMinBounces) return true;
  if (settings.roulette == RouletteRule::kThroughput && bounces >= settings.maxBounces) return true;
  const float largest = std::max({throughput.r, throughput.g, throughput.b});
  const float q =
      settings.roulette == RouletteRule::kMax ? std::min(1.0f, largest) : std::min(1.0f, std::sqrt(largest * etaScale));
  if (q >= 1.0f) return true;
  if (rng.get1D(base + dims::kRoulette) >= q) return false;
  throughput /= q;
  return true;
}

// The path takes a sampled direction (its weight, density, eta): false
// where it ends there (nothing left to carry, or Russian roulette). The caller sets the ray.
inline bool scatter(const RenderScene& rs, const SampleStream& rng, uint32_t base, bool counts, const MaterialSample& s,
                    PathState& path) {
  path.throughput *= s.weight;
  if (isBlack(path.throughput)) return false;
  if (counts) ++path.bounces;
  path.etaScale *= s.eta * s.eta;
  if (!survivesRoulette(rs.settings(), rng, base, path.bounces, path.etaScale, path.throughput)) return false;
  path.lastSpecular = s.specular;
  path.lastPdf = s.pdf;
  return true;
}

// A guided vertex's scattered direction (render/path_guiding.h): from the field with probability
// kGuidedShare (uChoice below it), else from the material's cosine lobe; weighed f cos / p by the
// mixture's density p (`pdf`), so it is one sample of the one-sample MIS estimator. Empty where
// the direction carries nothing (below the surface).
template <typename EvalCos, typename Pdf>
inline std::optional<MaterialSample> sampleGuided(const GuidingField& guide, int region, float uChoice, Vec2 u,
                                                  const EvalCos& evalCos, const Pdf& pdf, const Material& material,
                                                  const Vec3& n) {
  Vec3 wi;
  if (uChoice < kGuidedShare) {
    wi = guide.sample(region, u);
  } else {
    const auto lobe = material.sampleLambertian(n, u);
    if (!lobe) return std::nullopt;
    wi = lobe->wi;
  }
  const float p = pdf(wi);
  const Spectrum f = evalCos(wi);
  if (!(p > 0.0f) || isBlack(f)) return std::nullopt;
  return MaterialSample{wi, f / p, p, false};
}

// What a path does at the surface its last ray hit, `segment` rays after the camera: emission
// reaching the sensor (MIS-weighted after a diffuse vertex), the bounce limit, one light sample
// (next-event estimation) prepared as a shadow query, then the scattered direction and Russian
// roulette. The caller casts the shadow ray and adds its contribution when it is unblocked; the
// additions to the radiance keep the order emission, light sample, as the seed's sum does.
// kThinWalls (the volume path tracer, whose shadow rays cross thin walls attenuated): a path that
// goes straight through a thin wall (MaterialSample::straight) meets no vertex there: the
// throughput takes the sample's weight, and the bounce count, roulette and the last vertex's
// density and kind (for the MIS of a light reached next) stay as they were. The light sample of
// the vertex before counts the light through the wall, attenuated by it, and the light reached
// through it is weighed against that sample as if the wall were not there: one strategy each.
template <bool kNee, bool kGeneral, bool kThinWalls = false>
inline VertexOutcome shadeVertex(const RenderScene& rs, const SampleStream& rng, int segment, const SurfaceHit& hit,
                                 PathState& path, ShadowQuery& shadow) {
  const RenderSettings& settings = rs.settings();
  constexpr bool nee = kNee;
  // NEE alone weights a light sample 1 and a scattered ray that hits a light after a diffuse
  // vertex 0; NEE + MIS weights both with the power heuristic. Either way each light path is
  // counted once.
  const bool mis = settings.integrator == IntegratorKind::kNeeMis;
  VertexOutcome outcome;
  const Material& material = rs.material(hit.material);

  addEmittedLight<kNee>(rs, hit, material, path);
  if (!material.reflects()) return outcome;

  const bool specular = kGeneral && material.isSpecular();
  const bool front = glm::dot(hit.n, -path.direction) >= 0.0f;  // wo on the front face's side
  const bool counts = !specular || settings.mirrorBouncesCount;
  const bool thinWall = kThinWalls && material.isThinWall();
  if (!thinWall && counts && path.bounces >= settings.maxBounces) return outcome;

  const Vec3 wo = -path.direction;
  const Vec3 ng = front ? hit.n : -hit.n;  // shade the side we came from
  const uint32_t base = dims::segment(uint32_t(segment));

  // Where the surface varies (vertex normals, textures): the shading normal and, for a textured
  // material, the principled model with the textures' values at this point.
  const bool shaded = kGeneral && rs.shaded(hit.material);
  const ShadingPoint sp = shaded ? shadingPoint(rs, hit, wo, ng, front) : ShadingPoint{ng, {}, 0.0f};
  const Vec3& n = sp.n;
  std::optional<PrincipledBsdf> local;
  if (shaded && material.varies()) local.emplace(material.principledAt(sp.uv, sp.footprint));
  const auto evalCos = [&](const Vec3& wi) {
    if (shaded && !scattersTo(wi, ng, n)) return Spectrum(0.0f);
    return local ? local->evalCos(n, wo, wi, front) : material.evalCos(n, wo, wi, front);
  };
  // A guided vertex (render/path_guiding.h): a Lambertian one in a region where the field has
  // learned a distribution; its directions come from the mixture of the field and the cosine lobe.
  const bool guidable = !local && material.isLambertian() && (path.guide || path.recorder);
  const int region = guidable && path.guide ? path.guide->regionAt(hit.p) : -1;
  const auto pdf = [&](const Vec3& wi) {
    const float p = local ? local->pdf(n, wo, wi, front) : material.pdf(n, wo, wi, front);
    return region >= 0 ? guidedPdf(path.guide->pdf(region, wi), p) : p;
  };

  // A thin wall: first whether the path crosses it straight, with the model's probability q
  // (Bsdf::straightProbability), as a null event before any bounce is counted; otherwise it is a
  // vertex with probability 1 - q, whose light sample is weighed by 1 / (1 - q). (Its scattered
  // sample needs no such factor: drawn from the same uLobe >= q, its weight f / pdf already holds
  // the density of the non-straight lobes.)
  float vertexWeight = 1.0f;
  if (thinWall) {
    const float uLobe = rng.get1D(base + dims::kMaterialLobe);
    const float q = local ? local->straightProbability(n, wo) : material.straightProbability(n, wo);
    if (uLobe < q) {
      const auto s = local ? local->sample(n, wo, uLobe, rng.get2D(base + dims::kMaterial), front)
                           : material.sample(n, wo, uLobe, rng.get2D(base + dims::kMaterial), front);
      if (!s || !s->straight) return outcome;
      path.throughput *= s->weight;
      if (isBlack(path.throughput)) return outcome;
      path.origin = spawnOrigin(hit.p, hit.plane(), s->wi);
      path.direction = s->wi;
      outcome.continues = outcome.straight = true;
      return outcome;
    }
    if (counts && path.bounces >= settings.maxBounces) return outcome;
    vertexWeight = 1.0f / (1.0f - q);
  }

  const bool lastBounce = nee && !specular && counts && isLastBounce(rs, path.bounces);

  // Next-event estimation: one shadow ray to a point on a light.
  if (nee && !specular) {
    const auto ls =
        rs.lights().sample(hit.p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
    if (ls && !isBlack(ls->radiance)) {
      const Vec3 toLight = ls->p - hit.p;
      const Vec3 wi = glm::normalize(toLight);
      const Spectrum f = evalCos(wi);
      if (!isBlack(f)) {
        shadow.from = spawnOrigin(hit.p, hit.plane(), wi);
        shadow.direction = spawnOrigin(ls->p, ls->plane(), -wi) - shadow.from;
        shadow.tFar = 1.0f - kShadowEpsilon;
        if (ls->reach > 0.0f) unitShadowRay(shadow.direction, ls->reach, shadow.direction, shadow.tFar);
        const float weight = mis && !lastBounce && !ls->delta ? powerHeuristic(ls->pdf, pdf(wi)) : 1.0f;
        shadow.contribution = path.throughput * f * ls->radiance * (vertexWeight * weight / ls->pdf);
        outcome.castShadow = true;
      }
    }
  }

  if (lastBounce) return outcome;

  // The lobe choice is drawn only where a model has lobes to choose (not Lambertian, not mirrors).
  const float uLobe = material.choosesLobe() || local ? rng.get1D(base + dims::kMaterialLobe) : 0.0f;
  const Vec2 uDirection = rng.get2D(base + dims::kMaterial);
  const auto s = region >= 0 ? sampleGuided(*path.guide, region, rng.get1D(base + dims::kMaterialLobe), uDirection,
                                            evalCos, pdf, material, n)
                 : local     ? local->sample(n, wo, uLobe, uDirection, front)
                 : kGeneral && !material.isLambertian() ? material.sample(n, wo, uLobe, uDirection, front)
                                                        : material.sampleLambertian(n, uDirection);
  if (!s || (shaded && !scattersTo(s->wi, ng, n))) return outcome;
  if (!scatter(rs, rng, base, counts, *s, path)) return outcome;
  if (guidable && path.recorder) path.recorder->add(hit.p, s->wi, s->pdf, path.throughput);
  path.vertex = hit.p;
  path.origin = spawnOrigin(hit.p, hit.plane(), s->wi);
  path.direction = s->wi;
  outcome.continues = true;
  return outcome;
}

}  // namespace lensfarm::path_vertex
