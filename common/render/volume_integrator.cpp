#include "common/render/volume_integrator.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

// A scattering event at p inside `medium`: one light sample through the media (next-event
// estimation), then the phase function's direction and Russian roulette. False where the path
// ends. `mediumBounces` counts the path's events so far.
template <bool kNee>
bool scatterInMedium(const RenderScene& rs, const SampleStream& rng, int segment, const Vec3& p, const Medium& medium,
                     int& mediumBounces, PathState& path, PathStats& stats) {
  const RenderSettings& settings = rs.settings();
  if (mediumBounces >= settings.maxMediumBounces || path.bounces >= settings.maxBounces) return false;
  const uint32_t base = dims::segment(uint32_t(segment));
  const Vec3 wo = -path.direction;
  const HenyeyGreenstein& phase = medium.phase();
  // Where every boundary of the medium stops shadow rays (a subsurface or glass mesh), a light
  // sample could only reach a light inside it: none is taken, and a light the scattered ray
  // reaches counts with weight 1 instead (set below), which keeps the estimate unbiased and
  // halves the rays of a random walk.
  const bool sampleLights = kNee && rs.shadowRaysLeave(&medium);
  // The last event the limit allows: its light sample alone carries the direct light (weight 1).
  const bool lastBounce = sampleLights && mediumBounces + 1 >= settings.maxMediumBounces && lastBounceCanEndPaths(rs);
  if (sampleLights) {
    const auto ls = rs.lights().sample(p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
    if (ls && !isBlack(ls->radiance)) {
      const Vec3 wi = glm::normalize(ls->p - p);
      const float f = phase.eval(wo, wi);
      if (f > 0.0f) {
        Vec3 direction = spawnOrigin(ls->p, ls->plane(), -wi) - p;
        float tFar = 1.0f - kShadowEpsilon;
        if (ls->reach > 0.0f) unitShadowRay(direction, ls->reach, direction, tFar);
        const bool mis = settings.integrator == IntegratorKind::kNeeMis;
        const float weight = mis && !lastBounce && !ls->delta ? powerHeuristic(ls->pdf, f) : 1.0f;
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
  bool fromCamera = true;    // no vertex yet: rays see what the camera sees (RayKind::kCamera)
  float sinceVertex = 0.0f;  // distance from the last vertex to the ray's origin (crossings)
  const int segments = volumePathSegmentLimit(rs.settings());
  int segment = 0;
  for (; segment < segments; ++segment) {
    ++stats.rays;
    const auto hit =
        rs.caster().intersect(path.origin, path.direction, fromCamera ? RayKind::kCamera : RayKind::kScattered);
    if (medium) {
      MediumRng mr(rng.streamKey(dims::segment(uint32_t(segment)) + dims::kRoulette));
      const float tMax = hit ? hit->t : std::numeric_limits<float>::infinity();
      const FreeFlight ff = medium->sampleFreeFlight(path.origin, path.direction, tMax, path.throughput, mr, mis);
      path.throughput *= ff.weight;
      if (isBlack(path.throughput)) break;
      if (ff.scattered) {
        const Vec3 p = path.origin + ff.t * path.direction;
        if (!scatterInMedium<kNee>(rs, rng, segment, p, *medium, mediumBounces, path, stats)) break;
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
