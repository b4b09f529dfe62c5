#include "render/integrator.h"

#include <algorithm>

#include "math/ray_offset.h"
#include "math/sampling.h"

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
  bool hitLight = false;

  explicit PathState(const CameraRay& ray) : origin(ray.origin), direction(ray.direction) {}
  PathState() = default;
};

// The shadow ray of a vertex's light sample and what it adds if nothing blocks it.
struct ShadowQuery {
  Vec3 from, to;  // the segment, both ends offset off their surfaces
  Spectrum contribution;
};

struct VertexOutcome {
  bool castShadow = false;  // `shadow` holds a light sample whose ray must be tested
  bool continues = false;   // `path` holds the next ray to cast
};

// What a path does at the surface its last ray hit, `segment` rays after the camera: emission
// reaching the sensor (MIS-weighted after a diffuse vertex), the bounce limit, one light sample
// (next-event estimation) prepared as a shadow query, then the scattered direction and Russian
// roulette. The caller casts the shadow ray and adds its contribution when it is unblocked; the
// additions to the radiance keep the order emission, light sample, as the seed's sum does.
template <bool kNee, bool kSpecular>
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

  // Light reached by the camera ray or a scattered ray.
  if (material.isEmissive()) {
    const Spectrum le = rs.lights().emitted(hit.triangle, path.direction);
    if (!isBlack(le)) {
      path.hitLight = true;
      float weight = 1.0f;
      if (nee && !path.lastSpecular)
        weight = mis ? powerHeuristic(path.lastPdf, rs.lights().pdf(hit.triangle, hit.t, path.direction)) : 0.0f;
      path.radiance += path.throughput * le * weight;
    }
  }
  if (!material.reflects()) return outcome;

  const bool specular = kSpecular && material.isSpecular();
  const bool counts = !specular || settings.mirrorBouncesCount;
  if (counts && path.bounces >= settings.maxBounces) return outcome;

  const Vec3 wo = -path.direction;
  const Vec3 n = glm::dot(hit.n, wo) >= 0.0f ? hit.n : -hit.n;  // shade the side we came from
  const uint32_t base = dims::segment(uint32_t(segment));

  // The last counted bounce: the next vertex would end the path at the bounce limit, so the
  // scattered ray could only bring back emission, light the light sample already estimates.
  // There the light sample alone (weight 1, a valid MIS weighting of one strategy) carries the
  // direct light and the scattered ray is not cast: about one ray in six fewer at B = 3, same
  // expectation (Furnace and Estimators tests). Not after a mirror could follow: a mirror that
  // does not count would carry the path on to the light (a caustic light sampling cannot see).
  const bool lastBounce = nee && !specular && counts && path.bounces + 1 >= settings.maxBounces &&
                          (!rs.mirrorsReachable() || settings.mirrorBouncesCount);

  // Next-event estimation: one shadow ray to a point on a light.
  if (nee && !specular) {
    const auto ls = rs.lights().sample(hit.p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
    if (ls && !isBlack(ls->radiance)) {
      const Vec3 toLight = ls->p - hit.p;
      const Vec3 wi = glm::normalize(toLight);
      const Spectrum f = material.evalCos(n, wo, wi);
      if (!isBlack(f)) {
        shadow.from = offsetRayOrigin(hit.p, hit.n, hit.pError, wi);
        shadow.to = offsetRayOrigin(ls->p, ls->n, ls->pError, -wi);
        const float weight = mis && !lastBounce ? powerHeuristic(ls->pdf, material.pdf(n, wo, wi)) : 1.0f;
        shadow.contribution = path.throughput * f * ls->radiance * (weight / ls->pdf);
        outcome.castShadow = true;
      }
    }
  }

  if (lastBounce) return outcome;

  const auto s = kSpecular ? material.sample(n, wo, rng.get2D(base + dims::kMaterial))
                           : material.sampleLambertian(n, rng.get2D(base + dims::kMaterial));
  if (!s) return outcome;
  path.throughput *= s->weight;
  if (isBlack(path.throughput)) return outcome;
  if (counts) ++path.bounces;
  // Russian roulette (optional, render.russian_roulette): from the second bounce on, a path
  // survives with probability q = min(1, max throughput component) and carries 1/q more, so
  // the estimate stays unbiased while dim paths stop early.
  if (settings.russianRoulette && path.bounces >= 2) {
    const float q = std::min(1.0f, std::max({path.throughput.r, path.throughput.g, path.throughput.b}));
    if (rng.get1D(base + dims::kRoulette) >= q) return outcome;
    path.throughput /= q;
  }
  path.lastSpecular = s->specular;
  path.lastPdf = s->pdf;
  path.origin = offsetRayOrigin(hit.p, hit.n, hit.pError, s->wi);
  path.direction = s->wi;
  outcome.continues = true;
  return outcome;
}

}  // namespace

template <bool kNee, bool kSpecular>
Spectrum tracePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats) {
  PathState path(cameraRay);
  ShadowQuery shadow;
  ++stats.paths;
  for (int segment = 0; segment < kMaxPathSegments; ++segment) {
    ++stats.rays;
    const auto hit = rs.caster().intersect(path.origin, path.direction, segment == 0 ? RayKind::kCamera : RayKind::kScattered);
    if (!hit) break;
    const VertexOutcome outcome = shadeVertex<kNee, kSpecular>(rs, rng, segment, *hit, path, shadow);
    if (outcome.castShadow) {
      ++stats.rays;
      if (!rs.caster().occluded(shadow.from, shadow.to - shadow.from, 1.0f - kShadowEpsilon))
        path.radiance += shadow.contribution;
    }
    if (!outcome.continues) break;
  }
  if (path.hitLight) ++stats.lightHits;
  return path.radiance;
}

template <bool kNee, bool kSpecular>
void tracePacket(const RenderScene& rs, const PathPacket& packet, Spectrum (&radiance)[kPacketWidth], PathStats& stats) {
  PathState paths[kPacketWidth];
  ShadowQuery shadows[kPacketWidth];
  RayPacket rays, shadowRays;
  RayCaster::PacketHits hits;
  bool blocked[kPacketWidth];
  rays.clear();
  for (int k = 0; k < packet.count; ++k) {
    paths[k] = PathState(packet.cameraRays[k]);
    rays.set(k, paths[k].origin, paths[k].direction);
  }
  stats.paths += uint64_t(packet.count);

  int live = packet.count;
  for (int segment = 0; segment < kMaxPathSegments && live > 0; ++segment) {
    stats.rays += uint64_t(live);
    rs.caster().intersect(rays, segment == 0 ? RayKind::kCamera : RayKind::kScattered, hits);
    shadowRays.clear();
    int shadowCount = 0;
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!rays.active(k)) continue;
      VertexOutcome outcome;
      if (hits.found[k]) outcome = shadeVertex<kNee, kSpecular>(rs, packet.rng[k], segment, hits.hit[k], paths[k], shadows[k]);
      if (outcome.castShadow) {
        shadowRays.set(k, shadows[k].from, shadows[k].to - shadows[k].from, 1.0f - kShadowEpsilon);
        ++shadowCount;
      }
      if (outcome.continues) {
        rays.set(k, paths[k].origin, paths[k].direction);
      } else {
        rays.valid[k] = 0;
        --live;
      }
    }
    if (shadowCount > 0) {
      stats.rays += uint64_t(shadowCount);
      rs.caster().occluded(shadowRays, blocked);
      for (int k = 0; k < kPacketWidth; ++k)
        if (shadowRays.active(k) && !blocked[k]) paths[k].radiance += shadows[k].contribution;
    }
  }
  for (int k = 0; k < packet.count; ++k) {
    if (paths[k].hitLight) ++stats.lightHits;
    radiance[k] = paths[k].radiance;
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
