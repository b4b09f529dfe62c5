#include "render/integrator.h"

#include <algorithm>
#include <cmath>

#include "math/lanes.h"
#include "math/ray_offset.h"
#include "math/sampling.h"
#include "render/shading_point.h"

namespace lensfarm {

namespace {
// Shadow rays stop this fraction short of the light point (itself offset off the light).
constexpr float kShadowEpsilon = 1e-4f;

// One camera path between two ray casts.
struct PathState {
  Spectrum radiance{0.0f};
  Spectrum throughput{1.0f};
  Vec3 origin{0.0f}, direction{0.0f};  // the next ray to cast
  int bounces = 0;           // counted bounces so far (toward B)
  bool lastSpecular = true;  // the camera ray behaves like a specular one: no MIS for it
  float lastPdf = 0.0f;      // solid-angle pdf of the last scattered direction
  float etaScale = 1.0f;     // product of eta^2 over the refractions so far (Russian roulette)
  bool hitLight = false;
  // The path so far is one the light tracer also samples, once it reaches a light through a delta
  // vertex (render/light_tracer.h): its first vertex scattered by a non-delta lobe and every vertex
  // is of a material the light tracer handles. Only set while light tracing is on.
  bool lightTraced = false;

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
    // An emissive texture (never light-sampled: LightSampler leaves such emitters to the rays
    // that reach them, which count with weight 1).
    const Vec3 wo = -path.direction;
    const bool front = glm::dot(hit.n, wo) >= 0.0f;
    const ShadingPoint sp = shadingPoint(rs, hit, wo, front ? hit.n : -hit.n, front);
    le = le * glm::max(Spectrum(t->emissive.sample(sp.uv, sp.footprint)), Spectrum(0.0f));
    if (isBlack(le)) return;
  }
  path.hitLight = true;
  // Binary MIS with the light tracer (render/light_tracer.h): a light reached through a delta
  // vertex after a diffuse first vertex is the light tracer's to count, where it emits.
  if (path.lightTraced && path.lastSpecular && rs.lights().samplesTriangle(hit.triangle)) return;
  const float weight =
      reachedLightWeight<kNee>(rs, path, [&] { return rs.lights().pdf(hit.triangle, hit.t, path.direction); });
  path.radiance += path.throughput * le * weight;
}

// The camera ray or a scattered ray left the scene: the radiance of the lights beyond it that it
// reaches (the environment, a sun with an angular diameter), each weighted as an emitter is. Only
// called where the scene has such lights (RenderScene::hasEscapeLights); the path ends.
template <bool kNee>
inline void addEscapedLight(const RenderScene& rs, PathState& path) {
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
  const float q = settings.roulette == RouletteRule::kMax ? std::min(1.0f, largest)
                                                          : std::min(1.0f, std::sqrt(largest * etaScale));
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

// What a path does at the surface its last ray hit, `segment` rays after the camera: emission
// reaching the sensor (MIS-weighted after a diffuse vertex), the bounce limit, one light sample
// (next-event estimation) prepared as a shadow query, then the scattered direction and Russian
// roulette. The caller casts the shadow ray and adds its contribution when it is unblocked; the
// additions to the radiance keep the order emission, light sample, as the seed's sum does.
template <bool kNee, bool kGeneral>
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
  if (counts && path.bounces >= settings.maxBounces) return outcome;

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
  const auto pdf = [&](const Vec3& wi) { return local ? local->pdf(n, wo, wi, front) : material.pdf(n, wo, wi, front); };

  const bool lastBounce = nee && !specular && counts && isLastBounce(rs, path.bounces);

  // Next-event estimation: one shadow ray to a point on a light.
  if (nee && !specular) {
    const auto ls = rs.lights().sample(hit.p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
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
        shadow.contribution = path.throughput * f * ls->radiance * (weight / ls->pdf);
        outcome.castShadow = true;
      }
    }
  }

  if (lastBounce) return outcome;

  // The lobe choice is drawn only where a model has lobes to choose (not Lambertian, not mirrors).
  const float uLobe = material.choosesLobe() || local ? rng.get1D(base + dims::kMaterialLobe) : 0.0f;
  const Vec2 uDirection = rng.get2D(base + dims::kMaterial);
  const auto s = local                                 ? local->sample(n, wo, uLobe, uDirection, front)
                 : kGeneral && !material.isLambertian() ? material.sample(n, wo, uLobe, uDirection, front)
                                                        : material.sampleLambertian(n, uDirection);
  if (!s || (shaded && !scattersTo(s->wi, ng, n))) return outcome;
  if (!scatter(rs, rng, base, counts, *s, path)) return outcome;
  path.origin = spawnOrigin(hit.p, hit.plane(), s->wi);
  path.direction = s->wi;
  outcome.continues = true;
  return outcome;
}

}  // namespace

template <bool kNee, bool kGeneral>
Spectrum tracePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats) {
  PathState path(cameraRay);
  ShadowQuery shadow;
  ++stats.paths;
  const int segments = pathSegmentLimit(rs.settings().maxBounces);
  for (int segment = 0; segment < segments; ++segment) {
    ++stats.rays;
    const auto hit = rs.caster().intersect(path.origin, path.direction, segment == 0 ? RayKind::kCamera : RayKind::kScattered);
    if (!hit) {
      if (rs.hasEscapeLights()) addEscapedLight<kNee>(rs, path);
      break;
    }
    const VertexOutcome outcome = shadeVertex<kNee, kGeneral>(rs, rng, segment, *hit, path, shadow);
    if (rs.lightTracing())
      path.lightTraced = stillLightTraced(rs, segment, hit->material, path.lightTraced, path.lastSpecular);
    if (outcome.castShadow) {
      ++stats.rays;
      if (!rs.caster().occluded(shadow.from, shadow.direction, shadow.tFar))
        path.radiance += shadow.contribution;
    }
    if (!outcome.continues) break;
    if (segment + 1 == segments) ++stats.truncated;
  }
  if (path.hitLight) ++stats.lightHits;
  return path.radiance;
}

namespace {
// The paths of a packet as arrays over the lanes: PathState's fields but the ray, which is the
// packet's own RayPacket (the ray cast last until the segment's vertices set the next one).
struct PathLanes {
  alignas(64) float rr[kPacketWidth], rg[kPacketWidth], rb[kPacketWidth];  // radiance
  alignas(64) float tr[kPacketWidth], tg[kPacketWidth], tb[kPacketWidth];  // throughput
  alignas(64) float lastPdf[kPacketWidth];
  alignas(64) float etaScale[kPacketWidth];
  alignas(64) int bounces[kPacketWidth];
  alignas(64) int lastSpecular[kPacketWidth];  // 1 or 0 (an int, so lane loops can set it)
  bool hitLight[kPacketWidth];
  bool lightTraced[kPacketWidth];

  // A fresh path for every lane: what PathState starts with.
  void start() {
    for (int k = 0; k < kPacketWidth; ++k) {
      rr[k] = rg[k] = rb[k] = 0.0f;
      tr[k] = tg[k] = tb[k] = 1.0f;
      lastPdf[k] = 0.0f;
      etaScale[k] = 1.0f;
      bounces[k] = 0;
      lastSpecular[k] = 1;
      hitLight[k] = false;
      lightTraced[k] = false;
    }
  }
  // One lane as a PathState, for the one-path code (shadeVertex, addEmittedLight), and back.
  PathState get(int k, const RayPacket& rays) const {
    PathState path;
    path.radiance = Spectrum(rr[k], rg[k], rb[k]);
    path.throughput = Spectrum(tr[k], tg[k], tb[k]);
    path.origin = rays.origin(k), path.direction = rays.direction(k);
    path.bounces = bounces[k];
    path.lastSpecular = lastSpecular[k] != 0;
    path.lastPdf = lastPdf[k];
    path.etaScale = etaScale[k];
    path.hitLight = hitLight[k];
    path.lightTraced = lightTraced[k];
    return path;
  }
  void put(int k, const PathState& path) {
    rr[k] = path.radiance.r, rg[k] = path.radiance.g, rb[k] = path.radiance.b;
    tr[k] = path.throughput.r, tg[k] = path.throughput.g, tb[k] = path.throughput.b;
    bounces[k] = path.bounces;
    lastSpecular[k] = path.lastSpecular ? 1 : 0;
    lastPdf[k] = path.lastPdf;
    etaScale[k] = path.etaScale;
    hitLight[k] = path.hitLight;
    lightTraced[k] = path.lightTraced;
  }
};

// The diffuse (Lambertian) vertices of a packet's lanes at one segment, as arrays over the lanes:
// their shadow rays and their scattered directions are each one loop over all lanes that the
// compiler vectorises (math/lanes.h). Per lane the loops compute what shadeVertex computes, with
// the same operations in the same order, so the bits are the same (packet_integrator_test.cpp).
// The hit point, its normal and error bound are read from the packet's hits (RayCaster::PacketHits).
struct DiffuseLanes {
  alignas(64) float nx[kPacketWidth], ny[kPacketWidth], nz[kPacketWidth];  // normal on the side of wo
  alignas(64) float ar[kPacketWidth], ag[kPacketWidth], ab[kPacketWidth];  // albedo
  alignas(64) float misOn[kPacketWidth];  // 1: the light sample takes the power heuristic's weight; 0: weight 1
  alignas(64) float u0[kPacketWidth], u1[kPacketWidth];  // the scattered direction's sample
  // Out: the scattered ray, its cosine with n (a direction only where it is above 0) and density.
  alignas(64) float ox[kPacketWidth], oy[kPacketWidth], oz[kPacketWidth];
  alignas(64) float dx[kPacketWidth], dy[kPacketWidth], dz[kPacketWidth];
  alignas(64) float cosTheta[kPacketWidth], pdf[kPacketWidth];
  // Out: the light sample's f cos (a shadow ray only where it is not black), and what the shadow
  // ray adds if nothing blocks it.
  alignas(64) float fr[kPacketWidth], fg[kPacketWidth], fb[kPacketWidth];
  alignas(64) float cr[kPacketWidth], cg[kPacketWidth], cb[kPacketWidth];
};
// (Flags are decided outside the lane loops: GCC keeps a loop scalar that stores a comparison.)

// Every lane's shading normal, on the side the ray came from (shadeVertex's n), and the light
// sample's reference point.
LENSFARM_LANE_LOOPS void orientNormals(const RayCaster::PacketHits& __restrict h, const RayPacket& __restrict rays,
                                       DiffuseLanes& __restrict v, LightSampleLanes& __restrict ls) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec3 g(h.nx[k], h.ny[k], h.nz[k]);
    const Vec3 n = glm::dot(g, -Vec3(rays.dx[k], rays.dy[k], rays.dz[k])) >= 0.0f ? g : -g;
    v.nx[k] = n.x, v.ny[k] = n.y, v.nz[k] = n.z;
    ls.refx[k] = h.px[k], ls.refy[k] = h.py[k], ls.refz[k] = h.pz[k];
  }
}

// Next-event estimation for every lane with a light sample: the shadow ray from the vertex to the
// light point and what it carries (shadeVertex's light-sample block). The caller switches on the
// rays that exist.
LENSFARM_LANE_LOOPS void prepareShadowRays(const RayCaster::PacketHits& __restrict h, const PathLanes& __restrict path,
                                           DiffuseLanes& __restrict v, const LightSampleLanes& __restrict ls,
                                           RayPacket& __restrict shadowRays) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec3 p(h.px[k], h.py[k], h.pz[k]), lightPoint(ls.px[k], ls.py[k], ls.pz[k]);
    const Vec3 n(v.nx[k], v.ny[k], v.nz[k]);
    const Spectrum radiance(ls.rr[k], ls.rg[k], ls.rb[k]);
    const Vec3 wi = glm::normalize(lightPoint - p);
    const Spectrum f = lambertianEvalCos(Spectrum(v.ar[k], v.ag[k], v.ab[k]), n, wi);
    const Vec3 from = spawnOrigin(p, Vec3(h.v0x[k], h.v0y[k], h.v0z[k]), Vec3(h.nx[k], h.ny[k], h.nz[k]), h.margin[k], wi);
    const Vec3 to = spawnOrigin(lightPoint, Vec3(ls.v0x[k], ls.v0y[k], ls.v0z[k]), Vec3(ls.nx[k], ls.ny[k], ls.nz[k]),
                                ls.margin[k], -wi);
    const float weight = v.misOn[k] != 0.0f ? powerHeuristic(ls.pdf[k], lambertianPdf(n, wi)) : 1.0f;
    const Spectrum c = Spectrum(path.tr[k], path.tg[k], path.tb[k]) * f * radiance * (weight / ls.pdf[k]);
    const Vec3 d = to - from;
    shadowRays.ox[k] = from.x, shadowRays.oy[k] = from.y, shadowRays.oz[k] = from.z;
    shadowRays.dx[k] = d.x, shadowRays.dy[k] = d.y, shadowRays.dz[k] = d.z;
    shadowRays.tFar[k] = 1.0f - kShadowEpsilon;
    v.fr[k] = f.r, v.fg[k] = f.g, v.fb[k] = f.b;
    v.cr[k] = c.r, v.cg[k] = c.g, v.cb[k] = c.b;
  }
}

// The scattered direction of every lane that takes one: a cosine-weighted direction about n
// (Material::sampleLambertian) and the ray leaving the surface along it.
LENSFARM_LANE_LOOPS void sampleDirections(const RayCaster::PacketHits& __restrict h, DiffuseLanes& __restrict v) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec3 local = sampleCosineHemisphere(Vec2(v.u0[k], v.u1[k]));
    const Vec3 wi = Frame::fromNormal(Vec3(v.nx[k], v.ny[k], v.nz[k])).toWorld(local);
    const Vec3 o = spawnOrigin(Vec3(h.px[k], h.py[k], h.pz[k]), Vec3(h.v0x[k], h.v0y[k], h.v0z[k]),
                               Vec3(h.nx[k], h.ny[k], h.nz[k]), h.margin[k], wi);
    v.cosTheta[k] = local.z;
    v.pdf[k] = cosineHemispherePdf(local.z);
    v.ox[k] = o.x, v.oy[k] = o.y, v.oz[k] = o.z;
    v.dx[k] = wi.x, v.dy[k] = wi.y, v.dz[k] = wi.z;
  }
}

// What each lane's vertex does, as masks over the lanes (~0u or 0): the decisions shadeVertex
// makes before its light sample, for every lane at once.
struct VertexLanes {
  alignas(64) uint32_t special[kPacketWidth];  // a mirror or an emitter: the one-path code runs first
  alignas(64) uint32_t diffuse[kPacketWidth];  // a diffuse vertex within the bounce limit: the lane loops
};
struct ClassifyRules {
  int maxBounces;
  uint32_t generalMaterials;   // ~0u where materials beyond Lambertian are compiled in (kGeneral)
  uint32_t nee;                // ~0u with next-event estimation
  uint32_t mis;                // ~0u with NEE + MIS
  uint32_t lastBounceEnds;     // ~0u with NEE where lastBounceCanEndPaths (isLastBounce)
};

LENSFARM_LANE_LOOPS void classifyVertices(const RayCaster::PacketHits& __restrict h, const PathLanes& __restrict path,
                                          GatherView<RenderScene::MaterialRecord> materials, ClassifyRules rules,
                                          VertexLanes& __restrict out, DiffuseLanes& __restrict v,
                                          LightSampleLanes& __restrict ls, int* __restrict goes) {
  using Record = RenderScene::MaterialRecord;
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t hit = uint32_t(h.found[k]), m = h.material[k];
    const uint32_t general = materials.u(m, offsetof(Record, general)) & rules.generalMaterials;
    const uint32_t emissive = materials.u(m, offsetof(Record, emissive));
    const uint32_t reflects = materials.u(m, offsetof(Record, reflects));
    const uint32_t withinLimit = path.bounces[k] < rules.maxBounces ? ~0u : 0u;
    const uint32_t diffuse = hit & ~general & reflects & withinLimit;
    const uint32_t lastBounce = (path.bounces[k] + 1 >= rules.maxBounces ? ~0u : 0u) & rules.lastBounceEnds;
    out.special[k] = hit & (general | emissive);
    out.diffuse[k] = diffuse;
    ls.found[k] = int(diffuse & rules.nee);
    v.misOn[k] = (rules.mis & ~lastBounce) != 0 ? 1.0f : 0.0f;
    goes[k] = int(diffuse & ~lastBounce);
    const Spectrum albedo = materials.vec3(m, offsetof(Record, albedo));
    v.ar[k] = albedo.r, v.ag[k] = albedo.g, v.ab[k] = albedo.b;
  }
}

// The diffuse lanes that take their scattered direction (goes[k] -1): scatter() with the albedo
// as weight, but Russian roulette, which the caller applies. A lane whose direction does not
// exist (cosine not above 0: Material::sampleLambertian gives none) or whose throughput is black
// stops (goes[k] 0).
LENSFARM_LANE_LOOPS void scatterDiffuse(const DiffuseLanes& __restrict v, int* __restrict goes,
                                        PathLanes& __restrict path) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Spectrum t = Spectrum(path.tr[k], path.tg[k], path.tb[k]) * Spectrum(v.ar[k], v.ag[k], v.ab[k]);
    const bool on = goes[k] != 0 && v.cosTheta[k] > 0.0f && !isBlack(t);
    goes[k] = on ? -1 : 0;
    path.tr[k] = on ? t.r : path.tr[k], path.tg[k] = on ? t.g : path.tg[k], path.tb[k] = on ? t.b : path.tb[k];
    path.bounces[k] += on ? 1 : 0;
    path.lastSpecular[k] = on ? 0 : path.lastSpecular[k];
    path.lastPdf[k] = on ? v.pdf[k] : path.lastPdf[k];
  }
}

// The lanes that go on from a diffuse vertex (goes[k] -1) take their scattered ray.
LENSFARM_LANE_LOOPS void takeScatteredRays(const DiffuseLanes& __restrict v, const int* __restrict goes,
                                           RayPacket& __restrict rays) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const bool on = goes[k] != 0;
    rays.ox[k] = on ? v.ox[k] : rays.ox[k], rays.oy[k] = on ? v.oy[k] : rays.oy[k], rays.oz[k] = on ? v.oz[k] : rays.oz[k];
    rays.dx[k] = on ? v.dx[k] : rays.dx[k], rays.dy[k] = on ? v.dy[k] : rays.dy[k], rays.dz[k] = on ? v.dz[k] : rays.dz[k];
  }
}

// Shadow rays that reached their light add what they carry.
LENSFARM_LANE_LOOPS void addUnblocked(const DiffuseLanes& __restrict v, const int* __restrict unblocked,
                                      PathLanes& __restrict path) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const bool on = unblocked[k] != 0;
    path.rr[k] = on ? path.rr[k] + v.cr[k] : path.rr[k];
    path.rg[k] = on ? path.rg[k] + v.cg[k] : path.rg[k];
    path.rb[k] = on ? path.rb[k] + v.cb[k] : path.rb[k];
  }
}
}  // namespace

template <bool kNee, bool kGeneral>
void tracePacket(const RenderScene& rs, const PathPacket& packet, Spectrum (&radiance)[kPacketWidth], PathStats& stats) {
  const RenderSettings& settings = rs.settings();
  const bool mis = settings.integrator == IntegratorKind::kNeeMis;
  PathLanes paths;
  ShadowQuery generalShadows[kPacketWidth];  // the light samples of lanes at materials beyond Lambertian
  VertexLanes vertices;
  alignas(64) int goes[kPacketWidth], unblocked[kPacketWidth];
  RayPacket rays, shadowRays;
  RayCaster::PacketHits hits;
  bool blocked[kPacketWidth];
  // Lanes that are not in use still run through the lane loops, on what the packet's start or an
  // earlier segment left (finite values), and their results are ignored.
  DiffuseLanes v{};
  LightSampleLanes lights{};
  const SampleStream::LaneKeys keys = SampleStream::keysOf(packet.rng);
  const GatherView<RenderScene::MaterialRecord> materials(rs.materialRecords().data());
  const ClassifyRules rules{settings.maxBounces, kGeneral ? ~0u : 0u, kNee ? ~0u : 0u, mis ? ~0u : 0u,
                            kNee && lastBounceCanEndPaths(rs) ? ~0u : 0u};
  paths.start();
  rays.clear();
  for (int k = 0; k < packet.count; ++k) {
    const CameraRay ray = packet.cameraRays.ray(k);
    rays.set(k, ray.origin, ray.direction);
  }
  stats.paths += uint64_t(packet.count);

  int live = packet.count;
  const int segments = pathSegmentLimit(settings.maxBounces);
  for (int segment = 0; segment < segments && live > 0; ++segment) {
    stats.rays += uint64_t(live);
    rs.caster().intersect(rays, segment == 0 ? RayKind::kCamera : RayKind::kScattered, hits);
    shadowRays.clear();
    // Lanes whose ray left the scene end there, with the light beyond it (tracePath's miss).
    if (rs.hasEscapeLights())
      for (int k = 0; k < kPacketWidth; ++k) {
        if (!rays.active(k) || hits.found[k]) continue;
        PathState path = paths.get(k, rays);
        addEscapedLight<kNee>(rs, path);
        paths.put(k, path);
      }

    // The segment's sample values for all lanes: in vector loops (the same bits as each lane's
    // get1D / get2D) where the sampler has a lane form, always from the second vertex on and at
    // the first with the Sobol sampler; else stream by stream.
    const uint32_t segmentBase = dims::segment(uint32_t(segment));
    if (kNee) {
      SampleStream::values1D(packet.rng, keys, packet.count, segmentBase + dims::kLightChoice, lights.uChoice);
      SampleStream::values2D(packet.rng, keys, packet.count, segmentBase + dims::kLightPoint, lights.u0, lights.u1);
    }
    SampleStream::values2D(packet.rng, keys, packet.count, segmentBase + dims::kMaterial, v.u0, v.u1);

    // Every lane's decisions in one lane loop; then, lane by lane, the few that meet a mirror or
    // an emitter take the one-path code (shadeVertex, addEmittedLight).
    classifyVertices(hits, paths, materials, rules, vertices, v, lights, goes);
    alignas(64) int generalGoes[kPacketWidth] = {};
    bool generalShadow[kPacketWidth] = {};
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!vertices.special[k]) continue;
      const Material& material = rs.material(hits.material[k]);
      PathState path = paths.get(k, rays);
      const SurfaceHit hit = hits.hit(k);
      if (kGeneral && material.reflects() && (!material.isLambertian() || rs.shaded(hits.material[k]))) {
        const VertexOutcome outcome = shadeVertex<kNee, kGeneral>(rs, packet.rng[k], segment, hit, path, generalShadows[k]);
        generalShadow[k] = outcome.castShadow;
        if (outcome.continues) {
          rays.set(k, path.origin, path.direction);
          generalGoes[k] = -1;
        }
      } else {
        addEmittedLight<kNee>(rs, hit, material, path);
      }
      paths.put(k, path);
    }

    bool anyDiffuse = false;
    for (int k = 0; k < kPacketWidth; ++k) anyDiffuse |= vertices.diffuse[k] != 0;
    if (anyDiffuse) {
      // The lane loops, then each diffuse lane's path goes on along its scattered ray or ends.
      orientNormals(hits, rays, v, lights);
      if (kNee) {
        rs.lights().sample(lights);
        // A delta light's sample has MIS weight 1, and a light that is not a triangle a shadow ray
        // along a unit direction (shadeVertex).
        const bool otherLights = rs.lights().hasOtherLights();
        if (otherLights)
          for (int k = 0; k < kPacketWidth; ++k) v.misOn[k] = lights.delta[k] != 0 ? 0.0f : v.misOn[k];
        prepareShadowRays(hits, paths, v, lights, shadowRays);
        if (otherLights)
          for (int k = 0; k < kPacketWidth; ++k) {
            if (!(lights.reach[k] > 0.0f)) continue;
            Vec3 d = shadowRays.direction(k);
            unitShadowRay(d, lights.reach[k], d, shadowRays.tFar[k]);
            shadowRays.dx[k] = d.x, shadowRays.dy[k] = d.y, shadowRays.dz[k] = d.z;
          }
        for (int k = 0; k < kPacketWidth; ++k)
          shadowRays.valid[k] = lights.found[k] != 0 && !isBlack(Spectrum(lights.rr[k], lights.rg[k], lights.rb[k])) &&
                                        !isBlack(Spectrum(v.fr[k], v.fg[k], v.fb[k]))
                                    ? -1
                                    : 0;
      }
      sampleDirections(hits, v);
      scatterDiffuse(v, goes, paths);
      if (settings.roulette != RouletteRule::kOff)
        for (int k = 0; k < kPacketWidth; ++k) {
          if (!goes[k]) continue;
          Spectrum throughput(paths.tr[k], paths.tg[k], paths.tb[k]);
          if (!survivesRoulette(settings, packet.rng[k], segmentBase, paths.bounces[k], paths.etaScale[k], throughput)) {
            goes[k] = 0;
            continue;
          }
          paths.tr[k] = throughput.r, paths.tg[k] = throughput.g, paths.tb[k] = throughput.b;
        }
      takeScatteredRays(v, goes, rays);
    }
    // The lanes that go on: diffuse ones along their scattered ray, the others along theirs.
    live = 0;
    for (int k = 0; k < kPacketWidth; ++k) {
      rays.valid[k] = vertices.diffuse[k] ? goes[k] : generalGoes[k];
      live += rays.valid[k] != 0;
    }
    if (rs.lightTracing())
      for (int k = 0; k < kPacketWidth; ++k)
        if (rays.valid[k])
          paths.lightTraced[k] =
              stillLightTraced(rs, segment, hits.material[k], paths.lightTraced[k], paths.lastSpecular[k] != 0);
    // The light samples of lanes at glossy materials join the packet's shadow rays (after the
    // lane loops, which write every lane).
    if (kGeneral && kNee)
      for (int k = 0; k < kPacketWidth; ++k) {
        if (!generalShadow[k]) continue;
        const ShadowQuery& q = generalShadows[k];
        shadowRays.set(k, q.from, q.direction, q.tFar);
        v.cr[k] = q.contribution.r, v.cg[k] = q.contribution.g, v.cb[k] = q.contribution.b;
      }

    int shadowCount = 0;
    for (int k = 0; k < kPacketWidth; ++k) shadowCount += shadowRays.active(k);
    if (shadowCount > 0) {
      stats.rays += uint64_t(shadowCount);
      rs.caster().occluded(shadowRays, blocked);
      for (int k = 0; k < kPacketWidth; ++k) unblocked[k] = shadowRays.active(k) && !blocked[k] ? -1 : 0;
      addUnblocked(v, unblocked, paths);
    }
  }
  stats.truncated += uint64_t(live);
  for (int k = 0; k < packet.count; ++k) {
    if (paths.hitLight[k]) ++stats.lightHits;
    radiance[k] = Spectrum(paths.rr[k], paths.rg[k], paths.rb[k]);
  }
}

#define LENSFARM_INSTANTIATE(NEE, SPECULAR)                                                                        \
  template Spectrum tracePath<NEE, SPECULAR>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&); \
  template void tracePacket<NEE, SPECULAR>(const RenderScene&, const PathPacket&, Spectrum(&)[kPacketWidth], PathStats&);
LENSFARM_INSTANTIATE(false, false)
LENSFARM_INSTANTIATE(false, true)
LENSFARM_INSTANTIATE(true, false)
LENSFARM_INSTANTIATE(true, true)
#undef LENSFARM_INSTANTIATE

}  // namespace lensfarm
