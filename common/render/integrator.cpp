#include "render/integrator.h"

#include <algorithm>

#include "math/ray_offset.h"
#include "math/sampling.h"

namespace lensfarm {

namespace {
// Shadow rays stop this fraction short of the light point (itself offset off the light).
constexpr float kShadowEpsilon = 1e-4f;
}  // namespace

template <bool kNee, bool kSpecular>
Spectrum tracePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats) {
  const RenderSettings& settings = rs.settings();
  constexpr bool nee = kNee;
  // NEE alone weights a light sample 1 and a scattered ray that hits a light after a diffuse
  // vertex 0; NEE + MIS weights both with the power heuristic. Either way each light path is
  // counted once.
  const bool mis = settings.integrator == IntegratorKind::kNeeMis;
  const bool roulette = settings.russianRoulette;

  Spectrum radiance(0.0f);
  Spectrum throughput(1.0f);
  Vec3 origin = cameraRay.origin, direction = cameraRay.direction;
  RayKind kind = RayKind::kCamera;
  int bounces = 0;             // counted bounces so far (toward B)
  bool lastSpecular = true;    // the camera ray behaves like a specular one: no MIS for it
  float lastPdf = 0.0f;        // solid-angle pdf of the last scattered direction
  bool hitLight = false;

  ++stats.paths;
  for (int segment = 0; segment < kMaxPathSegments; ++segment) {
    ++stats.rays;
    const auto hit = rs.caster().intersect(origin, direction, kind);
    if (!hit) break;
    const Material& material = rs.material(hit->material);

    // Light reached by the camera ray or a scattered ray.
    if (material.isEmissive()) {
      const Spectrum le = rs.lights().emitted(hit->triangle, direction);
      if (!isBlack(le)) {
        hitLight = true;
        float weight = 1.0f;
        if (nee && !lastSpecular)
          weight = mis ? powerHeuristic(lastPdf, rs.lights().pdf(hit->triangle, hit->t, direction)) : 0.0f;
        radiance += throughput * le * weight;
      }
    }
    if (!material.reflects()) break;

    const bool specular = kSpecular && material.isSpecular();
    const bool counts = !specular || settings.mirrorBouncesCount;
    if (counts && bounces >= settings.maxBounces) break;

    const Vec3 wo = -direction;
    const Vec3 n = glm::dot(hit->n, wo) >= 0.0f ? hit->n : -hit->n;  // shade the side we came from
    const uint32_t base = dims::segment(uint32_t(segment));

    // Next-event estimation: one shadow ray to a point on a light.
    if (nee && !specular) {
      const auto ls = rs.lights().sample(hit->p, rng.get1D(base + dims::kLightChoice), rng.get2D(base + dims::kLightPoint));
      if (ls && !isBlack(ls->radiance)) {
        const Vec3 toLight = ls->p - hit->p;
        const Vec3 wi = glm::normalize(toLight);
        const Spectrum f = material.evalCos(n, wo, wi);
        if (!isBlack(f)) {
          const Vec3 from = offsetRayOrigin(hit->p, hit->n, hit->pError, wi);
          const Vec3 to = offsetRayOrigin(ls->p, ls->n, ls->pError, -wi);
          ++stats.rays;
          if (!rs.caster().occluded(from, to - from, 1.0f - kShadowEpsilon)) {
            const float weight = mis ? powerHeuristic(ls->pdf, material.pdf(n, wo, wi)) : 1.0f;
            radiance += throughput * f * ls->radiance * (weight / ls->pdf);
          }
        }
      }
    }

    const auto s = kSpecular ? material.sample(n, wo, rng.get2D(base + dims::kMaterial))
                             : material.sampleLambertian(n, rng.get2D(base + dims::kMaterial));
    if (!s) break;
    throughput *= s->weight;
    if (isBlack(throughput)) break;
    if (counts) ++bounces;
    // Russian roulette (optional, render.russian_roulette): from the second bounce on, a path
    // survives with probability q = min(1, max throughput component) and carries 1/q more, so
    // the estimate stays unbiased while dim paths stop early.
    if (roulette && bounces >= 2) {
      const float q = std::min(1.0f, std::max({throughput.r, throughput.g, throughput.b}));
      if (rng.get1D(base + dims::kRoulette) >= q) break;
      throughput /= q;
    }
    lastSpecular = s->specular;
    lastPdf = s->pdf;
    origin = offsetRayOrigin(hit->p, hit->n, hit->pError, s->wi);
    direction = s->wi;
    kind = RayKind::kScattered;
  }
  if (hitLight) ++stats.lightHits;
  return radiance;
}

template Spectrum tracePath<false, false>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);
template Spectrum tracePath<false, true>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);
template Spectrum tracePath<true, false>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);
template Spectrum tracePath<true, true>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&);

}  // namespace lensfarm
