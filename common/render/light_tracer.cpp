#include "common/render/light_tracer.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/math/ray_offset.h"
#include "common/math/sampling.h"
#include "common/render/light_emission.h"
#include "common/render/unit_renderer.h"

#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

namespace lensfarm {

namespace {

// One contribution of a particle vertex to a sensor cell, recorded by its
// chunk.
struct Splat {
  uint64_t cell;
  Spectrum value;
};

// What the particles of one unit share: the lights' cdf, the path limits.
struct Setup {
  const RenderScene& rs;
  SamplerSetup sampler;
  uint64_t key;  // the unit's stream key (its first sample and frame)
  // The emitters, by the flux they send where it counts: LightSampler::triangleLights() (when the
  // tracer emits from triangles), then the other lights in `others` (render/light_emission.h).
  std::vector<float> cdf, pmf;
  std::vector<const LightSource*> others;
  size_t triangles = 0;
  int segments, maxBounces;
  bool mirrorsCount;
};

// Connects the non-delta particle vertex `hit` (the particle arrived from w_l
// with weight beta) to a lens point: the contribution (LT) in the header,
// recorded as a splat.
void connect(const Setup& s, const SampleStream& rng, uint32_t base, const SurfaceHit& hit, const Material& material,
             const Vec3& wl, const Spectrum& beta, std::vector<Splat>& splats, PathStats& stats) {
  // The lens point, the cell it images the connection onto and the camera's importance there
  // (camera/camera.h, Camera::connect).
  const std::optional<CameraConnection> c = s.rs.camera().connect(hit.p, rng.get2D(base + dims::kLensPoint));
  if (!c) return;
  const Vec3 wc = c->toLens;
  const bool front = glm::dot(hit.n, wc) >= 0.0f;
  const Vec3 n = front ? hit.n : -hit.n;
  const float cosL = std::abs(glm::dot(n, wl)), cosC = glm::dot(n, wc);
  if (!(cosL > 0.0f) || !(cosC > 0.0f)) return;
  const Spectrum fCos = material.evalCos(n, wc, wl, front);  // f(w_c, w_l) |cos_l|
  if (isBlack(fCos)) return;
  // Visibility as a camera ray from the lens point sees it: the first surface
  // it meets is y.
  ++stats.rays;
  const auto seen = s.rs.caster().intersect(c->lensPoint, -wc, RayKind::kCamera);
  if (!seen || seen->triangle != hit.triangle || seen->instance != hit.instance ||
      std::abs(seen->t - c->distance) > 1e-3f * c->distance)
    return;
  const double w = c->importance * double(cosC) / (double(c->distance2) * double(cosL));
  const Spectrum contribution = beta * fCos * float(w);
  if (!isFinite(contribution)) return;
  splats.push_back(Splat{c->cell, contribution});
}

// One light path: emission, then each vertex (the path tracer's rules for B),
// connected to the camera where the path is one the light tracer takes.
void traceParticle(const Setup& s, uint64_t particle, std::vector<Splat>& splats, PathStats& stats) {
  const RenderScene& rs = s.rs;
  const SampleStream rng(s.sampler, s.key, particle);
  const uint32_t base0 = dims::segment(0);
  const size_t li = std::min<size_t>(
      size_t(std::upper_bound(s.cdf.begin(), s.cdf.end(), rng.get1D(base0 + dims::kLightChoice)) - s.cdf.begin()),
      s.cdf.size() - 1);
  const Vec2 uPoint = rng.get2D(base0 + dims::kLightPoint);
  Vec3 origin, direction;
  Spectrum beta;
  float reach = 0.0f;  // > 0: the particle starts off its light (LightEmission::reach)
  if (li < s.triangles) {
    const LightSampler::Light& light = rs.lights().triangleLights()[li];
    const Vec2 b = sampleUniformTriangle(uPoint);
    const Vec3 p = b.x * light.v0 + b.y * light.v1 + (1.0f - b.x - b.y) * light.v2;
    const Vec2 uDirection = rng.get2D(base0 + dims::kEmitDirection);
    const Spectrum le = light.emission * rs.lights().emissiveTexture(light, uPoint);
    if (const AimedDirection aim = aimAt(p, uDirection, rs.particleTarget()); aim.cone) {
      // Aimed at the delta surfaces (render/light_emission.h): beta_0 = L_e |cos| A / (P p(w)).
      const float cosL = glm::dot(light.n, aim.w);
      if (!(cosL > 0.0f) && !(light.twoSided > 0.0f && cosL < 0.0f)) return;
      direction = aim.w;
      beta = le * float(double(std::abs(cosL)) * light.area / (double(s.pmf[li]) * aim.pdf));
    } else {
      const bool back = light.twoSided > 0.0f && rng.get1D(base0 + dims::kMaterialLobe) < 0.5f;
      direction = Frame::fromNormal(back ? -light.n : light.n).toWorld(sampleCosineHemisphere(uDirection));
      // beta_0 = L_e cos / (P(light) / A * cos / pi [/ 2]) = L_e pi A / P(light) [x 2].
      beta = le * (kPi * light.area * (light.twoSided > 0.0f ? 2.0f : 1.0f) / s.pmf[li]);
    }
    origin = spawnOrigin(p, light.planeAt(p), direction);
  } else {
    const auto e = emitTowards(*s.others[li - s.triangles], rng.get2D(base0 + dims::kEmitDirection), uPoint,
                               rs.particleTarget(), rs.lights().sceneSphere());
    if (!e) return;
    origin = e->origin, direction = e->direction, reach = e->reach;
    beta = e->beta / s.pmf[li];
  }
  int bounces = 0;
  // Vertex v is reached by the v-th ray; its camera connection is the path's (v
  // + 1)-th segment.
  for (int v = 1; v < s.segments; ++v) {
    ++stats.rays;
    const auto hit = rs.caster().intersect(origin, direction, RayKind::kScattered);
    if (!hit) return;
    const Material& material = rs.material(hit->material);
    if (!material.reflects() || !rs.lightTraced(hit->material)) return;  // the path tracer's paths
    const bool specular = material.isSpecular();
    if (v == 1 && !specular) return;  // the vertex next to the light must be delta
    if (v == 1 && reach > 0.0f) {
      // A particle from an infinite light's disk: its light reaches it if nothing lies between.
      ++stats.rays;
      if (rs.caster().occluded(origin, -direction, reach)) return;
    }
    const bool counts = !specular || s.mirrorsCount;
    if (counts && bounces >= s.maxBounces) return;
    if (counts) ++bounces;
    const Vec3 wl = -direction;
    const bool front = glm::dot(hit->n, wl) >= 0.0f;
    const Vec3 n = front ? hit->n : -hit->n;
    const uint32_t base = dims::segment(uint32_t(v));
    if (!specular) connect(s, rng, base, *hit, material, wl, beta, splats, stats);
    if (v + 1 >= s.segments) return;  // a further vertex's connection would pass the segment limit
    const float uLobe = material.choosesLobe() ? rng.get1D(base + dims::kMaterialLobe) : 0.0f;
    const auto sample = material.sample(n, wl, uLobe, rng.get2D(base + dims::kMaterial), front);
    if (!sample) return;
    Spectrum weight = sample->weight;
    // The adjoint of a mirror's reflection (header): its sampling density is
    // symmetric, f cos is not. The adjoint of a refraction carries no 1/eta^2: particles carry
    // flux, not radiance (Veach 1997 §5.2; pbrt-v4's TransportMode::Importance).
    if (sample->eta != 1.0f)
      weight *= sample->eta * sample->eta;
    else if (specular)
      weight *= std::abs(glm::dot(n, sample->wi)) / std::abs(glm::dot(n, wl));
    beta *= weight;
    if (isBlack(beta) || !isFinite(beta)) return;
    direction = sample->wi;
    origin = spawnOrigin(hit->p, hit->plane(), direction);
  }
}

}  // namespace

uint64_t lightPathsOf(const RenderScene& rs, uint32_t samples) {
  const double n = std::ceil(rs.settings().lightTracingRatio * double(samples) * double(rs.camera().width()) *
                             double(rs.camera().height()));
  return std::max<uint64_t>(1, uint64_t(n));
}

bool traceLightPaths(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                     const std::atomic<bool>* cancel) {
  if (unit.sampleCount == 0) return true;
  const RenderSettings& settings = rs.settings();
  Setup s{rs,
          SamplerSetup{SamplerKind::kIndependent, settings.seed ^ 0x4c5452414345ull, 1, 1},
          0,
          {},
          {},
          {},
          0,
          pathSegmentLimit(settings.maxBounces),
          settings.maxBounces,
          settings.mirrorBouncesCount};
  s.key = SampleStream::mix(unit.firstSample ^ SampleStream::mix(uint64_t(unit.frame)));
  // Each emitter's flux: a triangle's pi A L_e [x 2] in the proportions of the light sampler's
  // pmf (which holds an emissive texture's mean), the other lights' towards the target.
  std::vector<double> flux;
  if (rs.lightTracesTriangles()) {
    double pmfs = 0.0, triangleFlux = 0.0;
    for (const auto& l : rs.lights().triangleLights()) {
      pmfs += l.pmf;
      triangleFlux += double(kPi) * l.area * luminance(l.emission) * (l.twoSided > 0.0f ? 2.0 : 1.0);
    }
    for (const auto& l : rs.lights().triangleLights()) flux.push_back(double(l.pmf) / pmfs * triangleFlux);
    s.triangles = flux.size();
  }
  for (const auto& light : rs.scene().lights)
    if (const double f = fluxTowards(*light, rs.particleTarget(), rs.lights().sceneSphere()); f > 0.0) {
      s.others.push_back(light.get());
      flux.push_back(f);
    }
  double total = 0.0;
  for (double f : flux) total += f;
  if (!(total > 0.0)) return true;
  double running = 0.0;
  for (double f : flux) {
    running += f;
    s.cdf.push_back(float(running / total));
    s.pmf.push_back(float(f / total));
  }
  s.cdf.back() = 1.0f;

  const uint64_t particles = lightPathsOf(rs, unit.sampleCount);
  const uint64_t chunks = (particles + kChunkParticles - 1) / kChunkParticles;
  std::vector<std::vector<Splat>> splats(chunks);
  tbb::combinable<PathStats> threadStats;
  std::atomic<bool> cancelled{false};
#if defined(__SSE__)
  const unsigned callerMode = _mm_getcsr();
#endif
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, chunks, 1), [&](const tbb::blocked_range<uint64_t>& range) {
#if defined(__SSE__)
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);  // as the pixel loop's threads
                                                 // (unit_renderer.cpp)
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    PathStats& local = threadStats.local();
    for (uint64_t c = range.begin(); c != range.end(); ++c) {
      if (cancel && cancel->load(std::memory_order_relaxed)) {
        cancelled = true;
        return;
      }
      const uint64_t end = std::min(particles, (c + 1) * kChunkParticles);
      for (uint64_t k = c * kChunkParticles; k < end; ++k) traceParticle(s, k, splats[c], local);
    }
  });
#if defined(__SSE__)
  _mm_setcsr(callerMode);
#endif
  threadStats.combine_each([&](const PathStats& st) { stats += st; });
  if (cancelled) return false;
  // n C / N into each cell's sums, in chunk order (the same bits for any thread
  // count).
  const double scale = double(unit.sampleCount) / double(particles);
  for (const auto& chunk : splats)
    for (const Splat& sp : chunk) {
      const size_t at = size_t(out.channels) * sp.cell;  // the beauty's RGB (no AOV sees a splat)
      out.sums[at] += scale * double(sp.value.r);
      out.sums[at + 1] += scale * double(sp.value.g);
      out.sums[at + 2] += scale * double(sp.value.b);
    }
  return true;
}

}  // namespace lensfarm
