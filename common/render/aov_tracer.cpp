#include "common/render/aov_tracer.h"

#include <optional>

#include "common/material/principled.h"
#include "common/math/ray_offset.h"
#include "common/render/render_scene.h"
#include "common/render/shading_point.h"

namespace lensfarm {

namespace {

// rho(wo) = integral of f |cos| over wi, estimated with a fixed stratified set of the model's own
// samples (4 x 4 directions x 16 lobe choices stratified together): the mean of their weights,
// f |cos| / pdf. Deterministic, so the AOV adds no noise of its own beyond the pixel's.
template <typename SampleFn>
Spectrum directionalAlbedo(SampleFn sample) {
  constexpr int kSide = 4;
  Spectrum sum(0.0f);
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j) {
      const float uLobe = (float(i * kSide + j) + 0.5f) / float(kSide * kSide);
      const Vec2 u((float(i) + 0.5f) / kSide, (float(j) + 0.5f) / kSide);
      if (const std::optional<MaterialSample> s = sample(uLobe, u)) sum += s->weight;
    }
  return sum / float(kSide * kSide);
}

// The delta lobe followed through a delta surface: a fixed lobe number near 1, which picks glass's
// transmission (its reflection only where Fresnel reflects everything, at total internal
// reflection) and a mirror's one lobe.
constexpr float kFollowedLobe = 0.999f;

}  // namespace

namespace {

// One sample's AOVs from its camera ray's first hit (nothing: the ray left the scene).
void addAovsFrom(const RenderScene& rs, const AovLayout& layout, Vec3 direction, std::optional<SurfaceHit> hit,
                 bool firstSample, double* cell) {
  Spectrum tint(1.0f);  // the delta lobes' weights so far
  for (int hop = 0;; ++hop) {
    if (!hit) return;  // albedo and normal 0 (and, for the camera ray, no depth)
    const Material& material = rs.material(hit->material);
    if (hop == 0) {
      if (layout.depth >= 0) {
        const ThinLensCamera& camera = rs.camera().paraxial();
        cell[layout.depth] += double(glm::dot(hit->p - camera.params().position, camera.forward()));
        cell[layout.depth + 1] += 1.0;
      }
      if (firstSample && layout.objectId >= 0) {
        const RayCaster::HitMesh m = rs.caster().hitMesh(*hit);
        const Scene& scene = rs.scene();
        cell[layout.objectId] += hit->instance != kNoInstance ? double(scene.meshes.size() + hit->instance) + 1.0
                                                              : double(m.mesh - scene.meshes.data()) + 1.0;
      }
      if (firstSample && layout.materialId >= 0) cell[layout.materialId] += double(hit->material) + 1.0;
    }
    if (layout.albedo < 0 && layout.normal < 0) return;
    if (!material.reflects()) return;  // a light or a black surface: albedo 0, no normal
    const Vec3 wo = -direction;
    const bool front = glm::dot(hit->n, wo) >= 0.0f;
    const Vec3 ng = front ? hit->n : -hit->n;
    const bool shaded = rs.shaded(hit->material);
    const ShadingPoint sp = shaded ? shadingPoint(rs, *hit, wo, ng, front) : ShadingPoint{ng, {}, 0.0f};
    std::optional<PrincipledBsdf> local;
    if (shaded && material.varies()) local.emplace(material.principledAt(sp.uv, sp.footprint));
    const auto sample = [&](float uLobe, Vec2 u) {
      return local ? local->sample(sp.n, wo, uLobe, u, front) : material.sample(sp.n, wo, uLobe, u, front);
    };
    if (material.isSpecular() && !local) {
      // Follow the delta lobe to the first surface that is not a mirror or smooth glass.
      if (hop == kAovSpecularHops) return;
      const std::optional<MaterialSample> s = sample(kFollowedLobe, Vec2(0.5f));
      if (!s) return;
      tint *= s->weight;
      direction = s->wi;
      hit = rs.caster().intersect(spawnOrigin(hit->p, hit->plane(), s->wi), s->wi, RayKind::kScattered);
      continue;
    }
    if (layout.albedo >= 0) {
      const Spectrum a = tint * (material.isLambertian() && !local ? material.albedo() : directionalAlbedo(sample));
      for (int c = 0; c < 3; ++c) cell[layout.albedo + c] += double(a[c]);
    }
    if (layout.normal >= 0)
      for (int c = 0; c < 3; ++c) cell[layout.normal + c] += double(sp.n[c]);
    return;
  }
}

}  // namespace

void addGeometricAovs(const RenderScene& rs, const AovLayout& layout, const CameraRay& ray, bool firstSample,
                      double* cell) {
  addAovsFrom(rs, layout, ray.direction, rs.caster().intersect(ray.origin, ray.direction, RayKind::kCamera),
              firstSample, cell);
}

void addGeometricAovs(const RenderScene& rs, const AovLayout& layout, const CameraRayLanes& rays, int count,
                      const bool (&firstSample)[kPacketWidth], double* const (&cells)[kPacketWidth]) {
  RayPacket packet;
  packet.clear();
  for (int k = 0; k < count; ++k) {
    const CameraRay ray = rays.ray(k);
    packet.set(k, ray.origin, ray.direction);
  }
  RayCaster::PacketHits hits;
  rs.caster().intersect(packet, RayKind::kCamera, hits);
  for (int k = 0; k < count; ++k)
    addAovsFrom(rs, layout, rays.ray(k).direction,
                hits.found[k] ? std::optional<SurfaceHit>(hits.hit(k)) : std::nullopt, firstSample[k], cells[k]);
}

}  // namespace lensfarm
