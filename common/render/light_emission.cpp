#include "common/render/light_emission.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/math/sampling.h"
#include "common/render/ray_caster.h"
#include "common/scene/scene.h"

namespace lensfarm {

namespace {

// The cone from q around the target sphere: its axis and 1 - cos(half-angle), computed without
// cancellation (1 - cos = sin^2 / (1 + cos)); 2 (the whole sphere) when q lies within the target
// or there is none.
struct AimCone {
  Vec3 axis{0.0f, 0.0f, 1.0f};
  double oneMinusCos = 2.0;
};

AimCone aimFrom(const Vec3& q, const SceneSphere& target) {
  const DVec3 d = DVec3(target.center) - DVec3(q);
  const double dist = glm::length(d), r = double(target.radius);
  if (!(dist > r) || !(r > 0.0)) return AimCone{};
  const double sin2 = (r / dist) * (r / dist), cosA = std::sqrt(1.0 - sin2);
  return AimCone{Vec3(d / dist), sin2 / (1.0 + cosA)};
}

}  // namespace

AimedDirection aimAt(const Vec3& q, Vec2 u, const SceneSphere& target) {
  // Uniform in the cone (or the sphere): 1 - cos(theta) uniform in [0, 1 - cos alpha].
  const AimCone cone = aimFrom(q, target);
  const double t = double(u.x) * cone.oneMinusCos;
  const double sinTheta = std::sqrt(std::max(0.0, t * (2.0 - t))), phi = 2.0 * std::numbers::pi * u.y;
  const Vec3 w = glm::normalize(Frame::fromNormal(cone.axis).toWorld(
      Vec3(float(sinTheta * std::cos(phi)), float(sinTheta * std::sin(phi)), float(1.0 - t))));
  return AimedDirection{w, 1.0 / (2.0 * std::numbers::pi * cone.oneMinusCos), cone.oneMinusCos < 2.0};
}

std::optional<LightEmission> emitTowards(const LightSource& light, Vec2 uDirection, Vec2 uPoint,
                                         const SceneSphere& target, const SceneSphere& scene) {
  if (!(target.radius > 0.0f)) return std::nullopt;
  if (const std::optional<Vec3> q = light.position()) {
    const AimedDirection aim = aimAt(*q, uDirection, target);
    // The light's intensity towards w: its light sample's radiance at unit distance, times r^2.
    const Vec3 ref = *q + aim.w;
    const std::optional<LightSample> s = light.sample(ref, uPoint, scene);
    if (!s || isBlack(s->radiance)) return std::nullopt;
    const Vec3 toLight = s->p - ref;
    return LightEmission{*q, aim.w, s->radiance * float(double(glm::dot(toLight, toLight)) / aim.pdf), 0.0f};
  }
  // An infinite light: its own direction sample, then a point on the target's disk across it.
  const std::optional<LightSample> s = light.sample(target.center, uDirection, scene);
  if (!s || isBlack(s->radiance) || !(s->pdf > 0.0f)) return std::nullopt;
  const Vec3 wl = glm::normalize(s->p - target.center);
  const Frame frame = Frame::fromNormal(wl);
  const Vec2 disk = sampleConcentricDisk(uPoint) * target.radius;
  const Vec3 origin = target.center + frame.toWorld(Vec3(disk.x, disk.y, 1.01f * target.radius));
  const float area = kPi * target.radius * target.radius;
  return LightEmission{origin, -wl, s->radiance * (area / s->pdf), SceneSphere::kReach * scene.radius};
}

double fluxTowards(const LightSource& light, const SceneSphere& target, const SceneSphere& scene) {
  if (!(target.radius > 0.0f)) return 0.0;
  if (const std::optional<Vec3> q = light.position())
    return std::numbers::pi * light.powerOverPi(scene) * aimFrom(*q, target).oneMinusCos / 2.0;
  return std::numbers::pi * light.powerOverPi(target);
}

SceneSphere targetSphere(const Scene& scene, const RayCaster& caster, const std::vector<uint8_t>& aimedAt) {
  DVec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  const auto add = [&](const DVec3& p) { lo = glm::min(lo, p), hi = glm::max(hi, p); };
  for (const RayCaster::Triangle& t : caster.triangles())
    if (aimedAt[t.material])
      for (const Vec3& v : {t.v0, t.v1, t.v2}) add(DVec3(v));
  const std::vector<std::pair<DVec3, DVec3>> boxes = instanceBoxes(scene);
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const TriangleMesh& prototype = scene.prototypes[scene.instances[i].prototype];
    if (std::any_of(prototype.materialIds.begin(), prototype.materialIds.end(), [&](uint32_t m) { return aimedAt[m]; }))
      add(boxes[i].first), add(boxes[i].second);
  }
  return lo.x > hi.x ? SceneSphere{} : SceneSphere::around(lo, hi);
}

}  // namespace lensfarm
