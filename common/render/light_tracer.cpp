#include "common/render/light_tracer.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/math/ray_offset.h"
#include "common/math/sampling.h"
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
  uint64_t key;            // the unit's stream key (its first sample and frame)
  std::vector<float> cdf;  // over LightSampler::triangleLights(), by power
  std::vector<float> pmf;  // the same, renormalised over the triangles
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
  const auto& lights = rs.lights().triangleLights();
  const uint32_t base0 = dims::segment(0);
  const size_t li = std::min<size_t>(
      size_t(std::upper_bound(s.cdf.begin(), s.cdf.end(), rng.get1D(base0 + dims::kLightChoice)) - s.cdf.begin()),
      lights.size() - 1);
  const LightSampler::Light& light = lights[li];
  const Vec2 uPoint = rng.get2D(base0 + dims::kLightPoint);
  const Vec2 b = sampleUniformTriangle(uPoint);
  const Vec3 p = b.x * light.v0 + b.y * light.v1 + (1.0f - b.x - b.y) * light.v2;
  const bool back = light.twoSided > 0.0f && rng.get1D(base0 + dims::kMaterialLobe) < 0.5f;
  const Vec3 ln = back ? -light.n : light.n;
  Vec3 direction = Frame::fromNormal(ln).toWorld(sampleCosineHemisphere(rng.get2D(base0 + dims::kEmitDirection)));
  // beta_0 = L_e cos / (P(light) / A * cos / pi [/ 2]) = L_e pi A / P(light) [x
  // 2].
  Spectrum beta = light.emission * rs.lights().emissiveTexture(light, uPoint) *
                  (kPi * light.area * (light.twoSided > 0.0f ? 2.0f : 1.0f) / s.pmf[li]);
  Vec3 origin = spawnOrigin(p, light.planeAt(p), direction);
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
    // symmetric, f cos is not.
    if (specular) weight *= std::abs(glm::dot(n, sample->wi)) / std::abs(glm::dot(n, wl));
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
  const auto& lights = rs.lights().triangleLights();
  if (lights.empty() || unit.sampleCount == 0) return true;
  const RenderSettings& settings = rs.settings();
  Setup s{rs,
          SamplerSetup{SamplerKind::kIndependent, settings.seed ^ 0x4c5452414345ull, 1, 1},
          0,
          {},
          {},
          pathSegmentLimit(settings.maxBounces),
          settings.maxBounces,
          settings.mirrorBouncesCount};
  s.key = SampleStream::mix(unit.firstSample ^ SampleStream::mix(uint64_t(unit.frame)));
  double total = 0.0;
  for (const auto& l : lights) total += l.pmf;
  double running = 0.0;
  for (const auto& l : lights) {
    running += l.pmf;
    s.cdf.push_back(float(running / total));
    s.pmf.push_back(float(l.pmf / total));
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
