#include "common/render/volume_integrator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/medium/equiangular.h"
#include "common/medium/homogeneous_medium.h"
#include "common/medium/medium.h"
#include "common/render/path_vertex.h"

namespace lensfarm {

using namespace path_vertex;

namespace {

// The medium a path is in after crossing a surface of material `m` in direction d (`n` the
// front face's normal): the material's interior against the normal, its exterior (or the
// scene's medium) along it; unchanged where the material bounds no medium.
inline const Medium* afterCrossing(const RenderScene& rs, const Material& m, const Vec3& n, const Vec3& d,
                                   const Medium* current) {
  if (!m.interior && !m.exterior) return current;
  if (glm::dot(d, n) < 0.0f) return m.interior ? m.interior.get() : current;
  return m.exterior ? m.exterior.get() : rs.scene().medium.get();
}

// A thin wall's straight transmittance for a ray along `dir` (BsdfTraits::thinWall), with the
// textures' values at the hit where the material has them.
Spectrum thinWallTransmittance(const RenderScene& rs, const SurfaceHit& hit, const Material& m, const Vec3& dir) {
  const Vec3 wo = -dir;
  const bool front = glm::dot(hit.n, wo) >= 0.0f;
  const Vec3 ng = front ? hit.n : -hit.n;
  if (!rs.shaded(hit.material)) return m.straightTransmittance(ng, wo);
  const ShadingPoint sp = shadingPoint(rs, hit, wo, ng, front);
  if (!m.varies()) return m.straightTransmittance(sp.n, wo);
  return PrincipledBsdf(m.principledAt(sp.uv, sp.footprint)).straightTransmittance(sp.n, wo);
}

// The fraction of light that arrives along the shadow ray from + t direction, t in (0, tFar)
// (direction need not be unit: tFar is in its units), starting in `medium`: the media's
// transmittance across every index-matched boundary it crosses and every thin wall's straight
// transmittance, 0 where another surface blocks it. A segment's tracking numbers come from a MediumRng keyed by (key,
// crossing).
Spectrum shadowTransmittance(const RenderScene& rs, Vec3 from, const Vec3& direction, float tFar, const Medium* medium,
                             uint64_t key, PathStats& stats) {
  const float length = glm::length(direction);
  const Vec3 dir = direction / length;
  const Vec3 end = from + dir * (tFar * length);
  float remaining = tFar * length;
  Spectrum tr(1.0f);
  for (int crossing = 0; crossing < kMaxCrossings; ++crossing) {
    ++stats.rays;
    const std::optional<SurfaceHit> hit = rs.caster().intersect(from, dir, RayKind::kScattered);
    const bool blocks = hit && hit->t < remaining;
    if (medium) {
      MediumRng mr(key + uint64_t(crossing) * 0x632be59bd9b4e019ull);
      tr *= medium->transmittance(from, dir, blocks ? hit->t : remaining, mr);
    }
    if (!blocks) return tr;
    const Material& m = rs.material(hit->material);
    if (m.isThinWall())
      tr *= thinWallTransmittance(rs, *hit, m, dir);
    else if (!m.passesThrough())
      return Spectrum(0.0f);
    if (isBlack(tr)) return Spectrum(0.0f);
    medium = afterCrossing(rs, m, hit->n, dir, medium);
    from = spawnOrigin(hit->p, hit->plane(), dir);
    remaining = glm::dot(end - from, dir);
    if (!(remaining > 0.0f)) return tr;
  }
  return Spectrum(0.0f);
}

// Whether a path may scatter once more (the limits on medium events and surface bounces).
bool mayScatter(const RenderSettings& settings, int mediumBounces, const PathState& path) {
  return mediumBounces < settings.maxMediumBounces && path.bounces < settings.maxBounces;
}

// Whether a scattering event now would be the last the limit allows: its light sample alone
// carries the direct light (weight 1) and no scattered ray is cast.
bool lastMediumEvent(const RenderScene& rs, int mediumBounces) {
  return mediumBounces + 1 >= rs.settings().maxMediumBounces && lastBounceCanEndPaths(rs);
}

// Equiangular sampling (medium/equiangular.h) joined to free-flight sampling. In a homogeneous
// scattering medium lit by a light at points, the direct light scattered along a ray segment
// [0, tMax) is the integral over t and over points x on the lights of
//     T(t) sigma_s phase(wo, wi) L_e(x) G(v(t), x) T(v(t), x),
// which three strategies sample: (d) a free-flight distance t, then a light point x (the
// vertex's light sample); (p) a free-flight distance t, then the phase function's direction,
// whose ray reaches x; (e) a light point x first (LightSampler::position), then t equiangularly
// towards it (this segment's own light sample, whether or not the path scatters in it). With
// the densities per unit t and per solid angle at v(t),
//     a = p_d(t) p_phase(wi),   b = p_d(t) p_light(wi),   c = p_e(t | x) p_light(wi),
// each sample is weighted by the power heuristic over the three, its own density squared over
// a^2 + b^2 + c^2 (Veach 1997 §9.2.2; weights that sum to 1 for every (t, x), whatever densities
// they use, keep the estimate unbiased). p_d is the free-flight density before spectral history
// (HomogeneousMedium::freeFlightDensity); a is 0 where the phase sample is not weighed against
// light samples (NEE alone, a delta light, the last event). Dividing by p_d:
//     w_d = b'^2 / (a'^2 + b'^2 (1 + r^2)),  w_e = b'^2 r^2 / (same),  r = p_e(t | x) / p_d(t),
// a' = p_phase, b' = p_light; the phase sample's weight is the power heuristic against
// p_light sqrt(1 + r^2) (path_vertex.h, MediumVertexMis). Infinite lights (directions, not
// points) keep the two-strategy weights of a vertex.
struct EquiangularWeights {
  float light, equiangular;  // w_d and w_e
};
// With a light tree, the light sample's choice (b') and the equiangular strategy's (by power:
// LightSampler::position) differ: c' = r p_byPower, and the weights are b'^2 and c'^2 over
// a'^2 + b'^2 + c'^2 (`byPower` equal to `lightPdf` without a tree: the form above).
EquiangularWeights equiangularWeights(float phasePdf, float lightPdf, double r, float byPower) {
  if (std::isinf(r)) return {0.0f, 1.0f};  // free flight cannot reach t (its density underflowed)
  const double a2 = double(phasePdf) * phasePdf, b2 = double(lightPdf) * lightPdf;
  const double c2 = lightPdf == byPower ? b2 * r * r : (r * byPower) * (r * byPower);
  const double sum = lightPdf == byPower ? a2 + b2 * (1.0 + r * r) : a2 + b2 + c2;
  if (!(sum > 0.0) || std::isinf(sum)) return {0.0f, 0.0f};
  return {float(b2 / sum), float(c2 / sum)};
}

// The segment of a path's ray in a medium equiangular sampling serves.
struct EquiangularSegmentOfPath {
  const HomogeneousMedium* fog;
  Vec3 origin, direction;
  float tMax;
};

// Strategy (e) for the segment: the light scattered towards the path at one equiangular t
// towards one light point, weighted against (d) and (p) (see above).
Spectrum equiangularDirect(const RenderScene& rs, const SampleStream& rng, int segment, const Medium& medium,
                           const EquiangularSegmentOfPath& seg, const PathState& path, bool lastEvent,
                           PathStats& stats) {
  const uint32_t base = dims::segment(uint32_t(segment));
  // The light point from the segment's light dimensions (the vertex a segment ends at draws the
  // same: correlated strategies, each unbiased), t from the segment's own stream.
  const float uChoice = rng.get1D(base + dims::kLightChoice);
  const Vec2 uPoint = rng.get2D(base + dims::kLightPoint);
  const std::optional<Vec3> x = rs.lights().position(uChoice, uPoint);
  if (!x) return Spectrum(0.0f);
  MediumRng mr(rng.streamKey(base + dims::kMaterialLobe) ^ 0x5851f42d4c957f2dull);
  const EquiangularSegment es = equiangularSegment(seg.origin, seg.direction, 0.0f, seg.tMax, *x);
  const float t = sampleEquiangular(es, mr());
  const float pe = equiangularPdf(es, t);
  if (!(pe > 0.0f)) return Spectrum(0.0f);
  const Vec3 v = seg.origin + t * seg.direction;
  // The same point x, seen from v: ls->pdf is the density of x by position()'s choice (c / p_e);
  // the light sample's own from v is that over positionPdfRatio (0 where a tree cannot choose it).
  const auto ls = rs.lights().samplePositioned(v, uChoice, uPoint);
  if (!ls || isBlack(ls->radiance)) return Spectrum(0.0f);
  const Vec3 wi = glm::normalize(ls->p - v);
  const float f = medium.phase().eval(-seg.direction, wi);
  if (!(f > 0.0f)) return Spectrum(0.0f);
  const bool mis = rs.settings().integrator == IntegratorKind::kNeeMis && !lastEvent && !ls->delta;
  const float lightPdf = ls->pdf / ls->positionPdfRatio;
  const float w =
      equiangularWeights(mis ? f : 0.0f, lightPdf, equiangularRatio(pe, seg.fog->freeFlightDensity(t)), ls->pdf)
          .equiangular;
  if (!(w > 0.0f)) return Spectrum(0.0f);
  Vec3 direction = spawnOrigin(ls->p, ls->plane(), -wi) - v;
  float tFar = 1.0f - kShadowEpsilon;
  if (ls->reach > 0.0f) unitShadowRay(direction, ls->reach, direction, tFar);
  const Spectrum tr = shadowTransmittance(rs, v, direction, tFar, &medium,
                                          rng.streamKey(base + dims::kMaterialLobe) ^ 0x2545f4914f6cdd1dull, stats);
  return path.throughput * seg.fog->transmittance(t) * seg.fog->sigmaS() * ls->radiance * tr * (f * w / (ls->pdf * pe));
}

// A scattering event at p inside `medium`: one light sample through the media (next-event
// estimation), then the phase function's direction and Russian roulette. False where the path
// ends. `mediumBounces` counts the path's events so far. Where equiangular sampling serves the
// segment (`seg`, at distance t), the light sample and the phase sample are weighted against it
// and `vertex` records the event for the light the scattered ray reaches.
template <bool kNee>
bool scatterInMedium(const RenderScene& rs, const SampleStream& rng, int segment, const Vec3& p, const Medium& medium,
                     const EquiangularSegmentOfPath* seg, float t, MediumVertexMis& vertex, int& mediumBounces,
                     PathState& path, PathStats& stats) {
  const RenderSettings& settings = rs.settings();
  if (!mayScatter(settings, mediumBounces, path)) return false;
  const uint32_t base = dims::segment(uint32_t(segment));
  const Vec3 wo = -path.direction;
  const HenyeyGreenstein& phase = medium.phase();
  // Where every boundary of the medium stops shadow rays (a subsurface or glass mesh), a light
  // sample could only reach a light inside it: none is taken, and a light the scattered ray
  // reaches counts with weight 1 instead (set below), which keeps the estimate unbiased and
  // halves the rays of a random walk.
  const bool sampleLights = kNee && rs.shadowRaysLeave(&medium);
  const bool lastBounce = sampleLights && lastMediumEvent(rs, mediumBounces);
  // The event as the three strategies' weights see it: one free-flight density for all of them.
  if (seg) vertex = MediumVertexMis{seg->origin, seg->direction, seg->tMax, t, seg->fog->freeFlightDensity(t)};
  if (sampleLights) {
    const auto ls = rs.lights().sample(p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
    if (ls && !isBlack(ls->radiance)) {
      const Vec3 wi = glm::normalize(ls->p - p);
      const float f = phase.eval(wo, wi);
      if (f > 0.0f) {
        Vec3 direction = spawnOrigin(ls->p, ls->plane(), -wi) - p;
        float tFar = 1.0f - kShadowEpsilon;
        if (ls->reach > 0.0f) unitShadowRay(direction, ls->reach, direction, tFar);
        const bool mis = settings.integrator == IntegratorKind::kNeeMis && !lastBounce && !ls->delta;
        float weight = mis ? powerHeuristic(ls->pdf, f) : 1.0f;
        if (seg && ls->reach <= 1.0f)  // a light at points (a triangle: 0; a point or spot: 1)
          weight =
              equiangularWeights(mis ? f : 0.0f, ls->pdf, vertex.ratio(ls->p), ls->pdf * ls->positionPdfRatio).light;
        const Spectrum tr =
            shadowTransmittance(rs, p, direction, tFar, &medium, rng.streamKey(base + dims::kLightPoint), stats);
        path.radiance += path.throughput * ls->radiance * tr * (f * weight / ls->pdf);
      }
    }
  }
  if (lastBounce) return false;
  const PhaseSample s = phase.sample(wo, rng.get2D(base + dims::kMaterial));
  ++mediumBounces;
  // Roulette by the medium events made (a long walk in a dim medium stops early, unbiased).
  if (!survivesRoulette(settings, rng, base, mediumBounces, path.etaScale, path.throughput)) return false;
  path.lastSpecular = !sampleLights;  // no light sample here: a light reached next weighs 1
  path.lastPdf = s.pdf;
  path.mediumVertex = seg ? &vertex : nullptr;
  path.vertex = p;
  path.origin = p;
  path.direction = s.wi;
  return true;
}

}  // namespace

template <bool kNee>
Spectrum traceVolumePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats) {
  PathState path(cameraRay);
  ShadowQuery shadow;
  ++stats.paths;
  const Medium* medium = rs.scene().medium.get();
  SpectralMis mis;  // the path's hero channel (medium/medium.h)
  mis.hero = std::min(2, int(MediumRng(rng.streamKey(dims::kHeroChannel))() * 3.0f));
  int mediumBounces = 0;
  MediumVertexMis vertexMis{};  // the last medium vertex, where path.mediumVertex points to it
  bool fromCamera = true;       // no vertex yet: rays see what the camera sees (RayKind::kCamera)
  float sinceVertex = 0.0f;     // distance from the last vertex to the ray's origin (crossings)
  const int segments = volumePathSegmentLimit(rs.settings());
  int segment = 0;
  for (; segment < segments; ++segment) {
    ++stats.rays;
    const auto hit =
        rs.caster().intersect(path.origin, path.direction, fromCamera ? RayKind::kCamera : RayKind::kScattered);
    if (medium) {
      MediumRng mr(rng.streamKey(dims::segment(uint32_t(segment)) + dims::kRoulette));
      const float tMax = hit ? hit->t : std::numeric_limits<float>::infinity();
      // Equiangular sampling's light for the segment, before free flight changes the throughput.
      const HomogeneousMedium* fog = kNee ? rs.equiangularIn(medium) : nullptr;
      const bool equiangular = fog && mayScatter(rs.settings(), mediumBounces, path);
      const EquiangularSegmentOfPath seg{fog, path.origin, path.direction, tMax};
      if (equiangular)
        path.radiance +=
            equiangularDirect(rs, rng, segment, *medium, seg, path, lastMediumEvent(rs, mediumBounces), stats);
      const FreeFlight ff = medium->sampleFreeFlight(path.origin, path.direction, tMax, path.throughput, mr, mis);
      path.throughput *= ff.weight;
      if (isBlack(path.throughput)) break;
      if (ff.scattered) {
        const Vec3 p = path.origin + ff.t * path.direction;
        if (!scatterInMedium<kNee>(rs, rng, segment, p, *medium, equiangular ? &seg : nullptr, ff.t, vertexMis,
                                   mediumBounces, path, stats))
          break;
        fromCamera = false;
        sinceVertex = 0.0f;
        continue;
      }
    }
    if (!hit) {
      if (rs.hasEscapeLights()) addEscapedLight<kNee>(rs, path);
      break;
    }
    const Material& material = rs.material(hit->material);
    if (material.passesThrough()) {  // an index-matched boundary: on along the same ray
      medium = afterCrossing(rs, material, hit->n, path.direction, medium);
      sinceVertex += hit->t;
      path.origin = spawnOrigin(hit->p, hit->plane(), path.direction);
      continue;
    }
    // The light's density for MIS is per solid angle at the last vertex: measure from there.
    SurfaceHit at = *hit;
    at.t += sinceVertex;
    const Vec3 incoming = path.direction;
    const VertexOutcome outcome = shadeVertex<kNee, true, true>(rs, rng, segment, at, path, shadow);
    if (outcome.castShadow) {
      // The shadow ray leaves on the side of its direction: through the surface into (or out of)
      // the material's interior where it is transmitted.
      const bool through = glm::dot(shadow.direction, hit->n) * glm::dot(incoming, hit->n) > 0.0f;
      const Medium* shadowMedium = through ? afterCrossing(rs, material, hit->n, shadow.direction, medium) : medium;
      const Spectrum tr =
          shadowTransmittance(rs, shadow.from, shadow.direction, shadow.tFar, shadowMedium,
                              rng.streamKey(dims::segment(uint32_t(segment)) + dims::kLightPoint), stats);
      path.radiance += shadow.contribution * tr;
    }
    if (!outcome.continues) break;
    if (glm::dot(path.direction, hit->n) * glm::dot(incoming, hit->n) > 0.0f)  // transmitted
      medium = afterCrossing(rs, material, hit->n, path.direction, medium);
    if (outcome.straight) {  // through a thin wall: no vertex, as across an interface
      sinceVertex += hit->t;
      continue;
    }
    path.mediumVertex = nullptr;  // a surface vertex scattered: its own MIS from here
    fromCamera = false;
    sinceVertex = 0.0f;
  }
  if (segment == segments) ++stats.truncated;
  if (path.hitLight) ++stats.lightHits;
  return path.radiance;
}

template Spectrum traceVolumePath<false>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);
template Spectrum traceVolumePath<true>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);

}  // namespace lensfarm
