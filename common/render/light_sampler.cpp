#include "common/render/light_sampler.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "common/math/lanes.h"
#include "common/math/ray_offset.h"
#include "common/math/sampling.h"
#include "common/math/spherical_triangle.h"
#include "common/math/triangle.h"

namespace lensfarm {

SceneSphere sceneSphereOf(const RayCaster& caster) {
  // The box of every vertex and the camera (render space's origin), in double.
  return SceneSphere::around(caster.boundsLo(), caster.boundsHi());
}

namespace {
// The point of triangle (a, b, c) closest to p (Ericson 2005, "Real-Time Collision Detection",
// 5.1.5: by the Voronoi regions of its vertices, edges and face).
DVec3 closestPointOnTriangle(const DVec3& p, const DVec3& a, const DVec3& b, const DVec3& c) {
  const DVec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const DVec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + ab * (d1 / (d1 - d3));
  const DVec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// The density (solid angle) of the point the solid-angle map gives ref on light l, chosen with
// probability pmf: pmf / Omega; 0 where ref sees none of the triangle.
float solidAnglePdf(const LightSampler::Light& l, const Vec3& ref, float pmf) {
  const std::optional<SphericalTriangle> st = SphericalTriangle::seen(ref, l.v0, l.v1, l.v2);
  return st ? float(double(pmf) / st->solidAngle) : 0.0f;
}

// For each light, whether a path vertex can lie within its reach where it emits: a triangle of
// the scene that reflects (not the light's own) comes within it, with a vertex off the light's
// plane on a side it emits to.
// Path vertices lie on surfaces, or anywhere in a medium: with media or instances (whose
// triangles are not in the caster's list), every light keeps its reach. The triangles are swept
// along x against the reaches; a scene where that takes too many tests keeps every reach too.
std::vector<bool> surfacesWithinReach(const Scene& scene, const RayCaster& caster,
                                      const std::vector<LightSampler::Light>& lights) {
  bool media = scene.medium != nullptr;
  for (const Material& m : scene.materials) media |= m.interior != nullptr || m.exterior != nullptr;
  if (media || !scene.instances.empty()) return std::vector<bool>(lights.size(), true);
  const auto& triangles = caster.triangles();
  std::vector<uint32_t> byLo(triangles.size());
  std::vector<float> lo(triangles.size()), hi(triangles.size());
  for (uint32_t k = 0; k < triangles.size(); ++k) {
    const auto& t = triangles[k];
    byLo[k] = k, lo[k] = std::min({t.v0.x, t.v1.x, t.v2.x}), hi[k] = std::max({t.v0.x, t.v1.x, t.v2.x});
  }
  std::sort(byLo.begin(), byLo.end(), [&](uint32_t a, uint32_t b) { return lo[a] < lo[b]; });
  std::vector<float> sortedLo(byLo.size());
  for (size_t j = 0; j < byLo.size(); ++j) sortedLo[j] = lo[byLo[j]];
  constexpr uint64_t kMaxTests = uint64_t(1) << 24;
  uint64_t tests = 0;
  std::vector<bool> reaches(lights.size(), false);
  for (size_t i = 0; i < lights.size(); ++i) {
    const auto& l = lights[i];
    if (!(l.solidAngleRadius2 > 0.0f)) continue;
    if (std::isinf(l.solidAngleRadius2)) {  // "solid_angle": everywhere, as asked
      reaches[i] = true;
      continue;
    }
    const double r2 = double(l.solidAngleRadius2), r = std::sqrt(r2);
    const DVec3 c(l.centroid), n(l.n);
    const auto end = std::upper_bound(sortedLo.begin(), sortedLo.end(), float(double(l.centroid.x) + r));
    for (auto it = sortedLo.begin(); it != end && !reaches[i]; ++it) {
      if (++tests > kMaxTests) return std::vector<bool>(lights.size(), true);
      const uint32_t k = byLo[size_t(it - sortedLo.begin())];
      const auto& t = triangles[k];
      if (k == l.triangle || double(hi[k]) < double(l.centroid.x) - r || !scene.materials[t.material].reflects())
        continue;  // a path ends on an emitter that reflects nothing
      const DVec3 a(t.v0), b(t.v1), d(t.v2);
      const DVec3 q = closestPointOnTriangle(c, a, b, d) - c;
      if (!(glm::dot(q, q) < r2)) continue;
      // Off the light's plane on a side it emits to (in its plane a point sees none of it).
      const double ha = glm::dot(a - c, n), hb = glm::dot(b - c, n), hd = glm::dot(d - c, n);
      const double tol = 1e-6 * std::max({glm::length(a - c), glm::length(b - c), glm::length(d - c)});
      reaches[i] = std::max({ha, hb, hd}) > tol || (l.twoSided != 0.0f && std::min({ha, hb, hd}) < -tol);
    }
  }
  return reaches;
}
}  // namespace

LightSampler::LightSampler(const Scene& scene, const RayCaster& caster, const std::vector<bool>& useful, bool deltaOnly,
                           bool tree, float solidAngleReach)
    : scene_(scene), caster_(caster), sphere_(sceneSphereOf(caster)) {
  const auto& triangles = caster.triangles();
  lightOfTriangle_.assign(triangles.size(), -1);
  double total = 0.0;
  std::vector<double> power;
  for (uint32_t k = 0; k < triangles.size() && !deltaOnly; ++k) {
    const auto& t = triangles[k];
    const Material& m = scene.materials[t.material];
    if (!m.isEmissive() || (!useful.empty() && !useful[t.material])) continue;
    // Emission that varies over the surface (an emissive texture): power by the texture's mean.
    const bool textured = m.textures() && m.textures()->emissive;
    const float area = float(triangleArea(t.v0, t.v1, t.v2));
    double p = double(area) * luminance(m.emission) * (m.twoSidedEmission ? 2.0 : 1.0);
    if (textured) p *= meanEmissiveTexture(k, m.textures()->emissive);
    if (!(p > 0.0)) continue;
    lightOfTriangle_[k] = int32_t(lights_.size());
    const Vec3 centroid = (t.v0 + t.v1 + t.v2) / 3.0f;
    const float radius = solidAngleReach * std::sqrt(std::max({glm::dot(t.v0 - centroid, t.v0 - centroid),
                                                               glm::dot(t.v1 - centroid, t.v1 - centroid),
                                                               glm::dot(t.v2 - centroid, t.v2 - centroid)}));
    lights_.push_back(Light{k, area, 0.0f, t.v0, t.v1, t.v2, t.n, t.margin, m.emission,
                            m.twoSidedEmission ? 1.0f : 0.0f, caster.isPrecise(k) ? 1.0f : 0.0f, t.material,
                            textured ? 1.0f : 0.0f, centroid, radius * radius});
    hasTextured_ |= textured;
    power.push_back(p);
    total += p;
  }
  // A light whose reach holds no surface in front of it never takes the solid-angle map; a scene
  // where none does skips the test per lane (reachLo_ above reachHi_).
  const std::vector<bool> reaches = surfacesWithinReach(scene, caster, lights_);
  for (size_t i = 0; i < lights_.size(); ++i) {
    Light& l = lights_[i];
    if (!reaches[i]) l.solidAngleRadius2 = 0.0f;
    if (!(l.solidAngleRadius2 > 0.0f)) continue;
    const float radius = std::sqrt(l.solidAngleRadius2);
    reachLo_ = glm::min(reachLo_, l.centroid - radius), reachHi_ = glm::max(reachHi_, l.centroid + radius);
  }
  if (lights_.size() > GatherView<Light>::kMaxRecords)  // the packet form's lane loop indexes them with 32 bits
    throw std::runtime_error("the scene has " + std::to_string(lights_.size()) + " emitting triangles; at most " +
                             std::to_string(GatherView<Light>::kMaxRecords) + " are supported");
  // The other lights follow the triangles in the cdf, so that without them nothing changes.
  std::vector<size_t> otherOfLight(scene.lights.size(), SIZE_MAX);
  for (size_t k = 0; k < scene.lights.size(); ++k) {
    const LightSource& light = *scene.lights[k];
    if (deltaOnly && !light.isDelta()) continue;
    const double p = light.powerOverPi(sphere_);
    if (!(p > 0.0)) continue;
    otherOfLight[k] = others_.size();
    others_.push_back(Other{&light, 0.0f});
    hasDelta_ |= light.isDelta();
    hasPositioned_ |= light.position().has_value();
    power.push_back(p);
    total += p;
  }
  double running = 0.0;
  for (size_t i = 0; i < power.size(); ++i) {
    (i < lights_.size() ? lights_[i].pmf : others_[i - lights_.size()].pmf) = float(power[i] / total);
    running += power[i] / total;
    cdf_.push_back(float(running));
  }
  if (!cdf_.empty()) cdf_.back() = 1.0f;
  for (size_t i = 0; i < kFewLights; ++i) fewCdf_[i] = i < cdf_.size() ? cdf_[i] : 2.0f;  // above any uChoice
  for (size_t k = 0; k < scene.lights.size(); ++k)
    if (scene.lights[k]->isReachedByEscapedRays())
      escapeLights_.push_back(
          EscapeLight{scene.lights[k].get(), otherOfLight[k] == SIZE_MAX ? 0.0f : others_[otherOfLight[k]].pmf});
  if (tree) buildTree(power);
}

void LightSampler::buildTree(const std::vector<double>& power) {
  // Each emitting triangle's bounds: its box, its peak intensity A L (its power over pi without the
  // second face's share) along its normal, emitting over the hemisphere (both, when two-sided).
  std::vector<LightBounds> bounds(size());
  for (size_t i = 0; i < lights_.size(); ++i) {
    const Light& l = lights_[i];
    const float intensity = float(power[i] / (l.twoSided != 0.0f ? 2.0 : 1.0));
    bounds[i] = LightBounds{glm::min(l.v0, glm::min(l.v1, l.v2)),
                            glm::max(l.v0, glm::max(l.v1, l.v2)),
                            intensity,
                            DirectionCone{l.n, 1.0f},
                            0.0f,
                            l.twoSided != 0.0f};
  }
  // The others in the scene bring their own; the infinite ones are chosen by power, before the tree.
  float running = 0.0f;
  for (size_t j = 0; j < others_.size(); ++j) {
    if (const std::optional<LightBounds> b = others_[j].light->bounds()) {
      bounds[lights_.size() + j] = *b;
      continue;
    }
    infinite_.push_back(j);
    running += others_[j].pmf;
    infiniteCdf_.push_back(running);
  }
  infinitePmf_ = infinite_.empty() ? 0.0f : std::min(running, 1.0f);
  tree_ = LightTree(bounds);
}

namespace {
// One light sample on a triangle, as seen from ref: the formula both sample() and the packet form
// below evaluate, without branches, so a loop over lanes vectorises (math/lanes.h).
struct TrianglePoint {
  Vec3 p;
  Spectrum radiance;
  float pdf;
  float dist2, cosLight;
  // Whether there is a sample at all: not for a degenerate point or direction, nor an infinite
  // density. (Tested outside lane loops: a flag computed inside one keeps it scalar.)
  bool valid() const { return dist2 > 0.0f && cosLight > 0.0f && std::isfinite(pdf); }
};

inline TrianglePoint sampleTrianglePoint(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& n, const Vec3& ref,
                                         Vec2 u, float pmf, float area, const Spectrum& emission, float twoSided) {
  const Vec2 b = sampleUniformTriangle(u);
  TrianglePoint s;
  s.p = b.x * v0 + b.y * v1 + (1.0f - b.x - b.y) * v2;
  const Vec3 toLight = s.p - ref;
  s.dist2 = glm::dot(toLight, toLight);
  const Vec3 d = toLight * (1.0f / std::sqrt(s.dist2));  // one division, not three
  s.cosLight = std::abs(glm::dot(n, d));
  // Emitted towards ref, zero where ref sees the back of a one-sided light.
  // (A product, not a select between emission and zero: the packet form gathers `emission` from
  // the lane's light, and a select would load it only in one branch, which keeps the loop scalar.)
  const float facing = twoSided != 0.0f || !(glm::dot(n, d) >= 0.0f) ? 1.0f : 0.0f;
  s.radiance = emission * facing;
  // Area density 1/A converted to solid angle: dist^2 / (cos A).
  s.pdf = pmf * s.dist2 / (s.cosLight * area);
  return s;
}

// Few lights: the cdf padded to a fixed length with entries no uChoice reaches, so choosing is
// a count without branches (a random uChoice would mispredict a search half the time) and the
// packet form's lane loop can choose for every lane.
inline uint32_t chooseAmongFew(const float (&cdf)[LightSampler::kFewLights], float uChoice) {
  uint32_t i = 0;
#pragma GCC unroll 8
  for (float c : cdf) i += uint32_t(c <= uChoice);
  return i;
}

// Up to kLights lights held by value for a lane loop: a lane's field of light i is picked with
// selects between that field of each light (loads at fixed places, hoisted out of the loop), not
// gathered lane by lane. Lights beyond the scene's repeat the first.
using Light = LightSampler::Light;
class SelectView {
 public:
  static constexpr uint32_t kLights = 4;
  SelectView(const Light* lights, size_t count) {
    for (uint32_t j = 0; j < kLights; ++j) lights_[j] = lights[j < count ? j : 0];
  }
  float f(uint32_t i, size_t offset) const {
    float x = at(0, offset);
#pragma GCC unroll 4
    for (uint32_t j = 1; j < kLights; ++j) x = i == j ? at(j, offset) : x;
    return x;
  }
  Vec3 vec3(uint32_t i, size_t offset) const {
    return Vec3(f(i, offset), f(i, offset + sizeof(float)), f(i, offset + 2 * sizeof(float)));
  }

 private:
  float at(uint32_t j, size_t offset) const {
    return reinterpret_cast<const float*>(&lights_[j])[offset / sizeof(float)];
  }
  Light lights_[kLights];
};

// The packet form's lane loops: lane k samples a point on light i, read from `lights` (a
// GatherView or a SelectView), by area; out per lane, the quantities TrianglePoint::valid() reads.
template <typename Lights>
[[gnu::always_inline]] inline void sampleLane(Lights lights, uint32_t i, float pmf, int k, LightSampleLanes& l,
                                              float* dist2, float* cosLight) {
  const Vec3 n = lights.vec3(i, offsetof(Light, n)), v0 = lights.vec3(i, offsetof(Light, v0));
  const TrianglePoint s = sampleTrianglePoint(
      lights.vec3(i, offsetof(Light, v0)), lights.vec3(i, offsetof(Light, v1)), lights.vec3(i, offsetof(Light, v2)), n,
      Vec3(l.refx[k], l.refy[k], l.refz[k]), Vec2(l.u0[k], l.u1[k]), pmf, lights.f(i, offsetof(Light, area)),
      lights.vec3(i, offsetof(Light, emission)), lights.f(i, offsetof(Light, twoSided)));
  l.px[k] = s.p.x, l.py[k] = s.p.y, l.pz[k] = s.p.z;
  l.nx[k] = n.x, l.ny[k] = n.y, l.nz[k] = n.z;
  const Vec3 anchor = lights.f(i, offsetof(Light, anchored)) > 0.0f ? s.p : v0;  // Light::planeAt
  l.v0x[k] = anchor.x, l.v0y[k] = anchor.y, l.v0z[k] = anchor.z;
  l.margin[k] = lights.f(i, offsetof(Light, margin));
  l.rr[k] = s.radiance.r, l.rg[k] = s.radiance.g, l.rb[k] = s.radiance.b;
  l.pdf[k] = s.pdf;
  dist2[k] = s.dist2, cosLight[k] = s.cosLight;
}

// Up to SelectView::kLights lights: each lane chooses its light and reads it with selects.
// Without branches, so the loops vectorise; lanes not asked for take light 0.
LENSFARM_LANE_LOOPS void sampleSelectedLanes(SelectView lights, uint32_t lastLight,
                                             const float (&cdf)[LightSampler::kFewLights],
                                             LightSampleLanes& __restrict l, uint32_t* __restrict chosen,
                                             float* __restrict dist2, float* __restrict cosLight) {
  float fewCdf[LightSampler::kFewLights];  // a copy nothing else can write (else GCC checks aliasing)
  std::copy(std::begin(cdf), std::end(cdf), fewCdf);
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t i = std::min(chooseAmongFew(fewCdf, l.uChoice[k]), lastLight) & uint32_t(l.found[k]);
    chosen[k] = i;
    sampleLane(lights, i, lights.f(i, offsetof(Light, pmf)), k, l, dist2, cosLight);
  }
}

// More lights: each lane gathers its light, chosen before the loop (`chosen`).
LENSFARM_LANE_LOOPS void sampleGatheredLanes(GatherView<Light> lights, const uint32_t* __restrict chosen,
                                             LightSampleLanes& __restrict l, float* __restrict dist2,
                                             float* __restrict cosLight) {
  for (int k = 0; k < kPacketWidth; ++k)
    sampleLane(lights, chosen[k], lights.f(chosen[k], offsetof(Light, pmf)), k, l, dist2, cosLight);
}

// The same with each lane's own probability of its light (a light tree's, LightSampler::chooseFrom).
LENSFARM_LANE_LOOPS void sampleGatheredLanesWithPmf(GatherView<Light> lights, const uint32_t* __restrict chosen,
                                                    const float* __restrict pmf, LightSampleLanes& __restrict l,
                                                    float* __restrict dist2, float* __restrict cosLight) {
  for (int k = 0; k < kPacketWidth; ++k) sampleLane(lights, chosen[k], pmf[k], k, l, dist2, cosLight);
}

// near[k] = 1 where lane k (found) takes its point on triangle chosen[k] by solid angle
// (LightSampler::bySolidAngle, written without branches so that the loop vectorises).
LENSFARM_LANE_LOOPS void markNearLanes(GatherView<Light> lights, const uint32_t* __restrict chosen,
                                       const LightSampleLanes& __restrict l, float* __restrict near) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t i = chosen[k];
    const Vec3 d = Vec3(l.refx[k], l.refy[k], l.refz[k]) - lights.vec3(i, offsetof(Light, centroid));
    const bool within = glm::dot(d, d) < lights.f(i, offsetof(Light, solidAngleRadius2));
    const bool facing =
        (lights.f(i, offsetof(Light, twoSided)) != 0.0f) | (glm::dot(d, lights.vec3(i, offsetof(Light, n))) > 0.0f);
    near[k] = (l.found[k] != 0) & within & facing ? 1.0f : 0.0f;
  }
}
}  // namespace

std::optional<LightSampler::Choice> LightSampler::chooseFrom(const Vec3& ref, float uChoice) const {
  if (!usesTree()) {
    const size_t i = choose(uChoice);
    return Choice{i, pmfByPower(i)};
  }
  if (uChoice < infinitePmf_) {
    const size_t k =
        std::min(size_t(std::upper_bound(infiniteCdf_.begin(), infiniteCdf_.end(), uChoice) - infiniteCdf_.begin()),
                 infinite_.size() - 1);
    return Choice{lights_.size() + infinite_[k], others_[infinite_[k]].pmf};
  }
  // The rest of [0, 1) stretched over the tree's choice.
  const float rest = 1.0f - infinitePmf_;
  const std::optional<LightTree::Choice> c =
      tree_.sample(ref, std::min((uChoice - infinitePmf_) / rest, 0x1.fffffep-1f));
  if (!c) return std::nullopt;
  return Choice{c->light, rest * c->pmf};
}

float LightSampler::pmfFrom(const Vec3& ref, size_t light) const {
  if (!usesTree() || chosenFirst(light)) return pmfByPower(light);
  return (1.0f - infinitePmf_) * tree_.pmf(ref, uint32_t(light));
}

size_t LightSampler::choose(float uChoice) const {
  // The first cdf entry above uChoice (std::upper_bound).
  const size_t count = size();
  const size_t i = count <= kFewLights ? chooseAmongFew(fewCdf_, uChoice)
                                       : size_t(std::upper_bound(cdf_.begin(), cdf_.end(), uChoice) - cdf_.begin());
  return std::min(i, count - 1);
}

std::optional<LightSample> LightSampler::sampleOther(size_t i, const Vec3& ref, Vec2 uPoint, float pmf) const {
  std::optional<LightSample> s = others_[i].light->sample(ref, uPoint, sphere_);
  if (!s) return std::nullopt;
  s->pdf *= pmf;
  if (!(s->pdf > 0.0f && std::isfinite(s->pdf))) return std::nullopt;
  return s;
}

namespace {
// Texture coordinates at barycentrics (b1, b2) of caster triangle k (render/shading_point.h's).
void textureCoordinatesAt(const RayCaster& caster, uint32_t k, float b1, float b2, Vec2 (&uv)[2]) {
  SurfaceHit at{};
  at.triangle = k;
  at.instance = kNoInstance;
  const RayCaster::HitMesh where = caster.hitMesh(at);
  for (int set = 0; set < 2; ++set)
    uv[set] =
        where.mesh->uv[set].empty() ? Vec2(0.0f) : where.mesh->interpolate(where.mesh->uv[set], where.index, b1, b2);
}
}  // namespace

float LightSampler::meanEmissiveTexture(uint32_t k, const TextureRef& texture) const {
  // 16 points of a 4 x 4 grid over the unit square, mapped onto the triangle as samples are,
  // each looked up with a footprint a quarter of the triangle's extent in texture space.
  Vec2 corners[3][2];
  for (int c = 0; c < 3; ++c) textureCoordinatesAt(caster_, k, c == 1 ? 1.0f : 0.0f, c == 2 ? 1.0f : 0.0f, corners[c]);
  const Vec2 e1 = corners[1][0] - corners[0][0], e2 = corners[2][0] - corners[0][0];
  const float footprint = 0.25f * std::sqrt(std::abs(e1.x * e2.y - e1.y * e2.x));
  double sum = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const Vec2 b = sampleUniformTriangle(Vec2((float(i) + 0.5f) / 4.0f, (float(j) + 0.5f) / 4.0f));
      Vec2 uv[2];
      textureCoordinatesAt(caster_, k, b.y, 1.0f - b.x - b.y, uv);
      sum += double(luminance(glm::max(Spectrum(texture.sample(uv, footprint)), Spectrum(0.0f))));
    }
  return float(sum / 16.0);
}

Spectrum LightSampler::emissiveTexture(const Light& l, Vec2 uPoint) const {
  if (l.textured == 0.0f) return Spectrum(1.0f);
  // The point sampleTrianglePoint takes: b.x v0 + b.y v1 + (1 - b.x - b.y) v2, so (b1, b2) = (b.y, 1 - b.x - b.y).
  const Vec2 b = sampleUniformTriangle(uPoint);
  return emissiveTextureAt(l, b.y, 1.0f - b.x - b.y);
}

Spectrum LightSampler::emissiveTextureAt(const Light& l, float b1, float b2) const {
  if (l.textured == 0.0f) return Spectrum(1.0f);
  Vec2 uv[2];
  textureCoordinatesAt(caster_, l.triangle, b1, b2, uv);
  return glm::max(Spectrum(scene_.materials[l.material].textures()->emissive.sample(uv, 0.0f)), Spectrum(0.0f));
}

std::optional<Vec3> LightSampler::position(float uChoice, Vec2 uPoint) const {
  if (empty()) return std::nullopt;
  const size_t i = choose(uChoice);
  if (i >= lights_.size()) return others_[i - lights_.size()].light->position();
  const Light& l = lights_[i];
  const Vec2 b = sampleUniformTriangle(uPoint);
  return b.x * l.v0 + b.y * l.v1 + (1.0f - b.x - b.y) * l.v2;  // sampleTrianglePoint's point
}

std::optional<LightSample> LightSampler::sampleTriangleBySolidAngle(size_t i, const Vec3& ref, Vec2 uPoint,
                                                                    float pmf) const {
  const Light& l = lights_[i];
  const std::optional<SphericalTriangle> st = SphericalTriangle::seen(ref, l.v0, l.v1, l.v2);
  if (!st) return std::nullopt;  // ref in the light's plane: it sees none of it
  // The direction, then the point where it meets the triangle's plane (in double: the direction
  // is a unit vector, the distance as precise as the plane).
  const DVec3 w = st->sample(uPoint), n(l.n), origin(ref);
  const double cosine = glm::dot(w, n);
  const double t = glm::dot(DVec3(l.v0) - origin, n) / cosine;
  if (!(t > 0.0) || !std::isfinite(t)) return std::nullopt;
  const DVec3 x = origin + t * w;
  const Vec3 p(x);
  const float pdf = float(double(pmf) / st->solidAngle);
  if (!(pdf > 0.0f) || !std::isfinite(pdf)) return std::nullopt;
  // Emitted towards ref, zero where ref sees the back of a one-sided light (sampleTrianglePoint's rule).
  const float facing = l.twoSided != 0.0f || !(cosine >= 0.0) ? 1.0f : 0.0f;
  Spectrum radiance = l.emission * facing;
  if (l.textured != 0.0f) {
    const glm::dvec2 b = triangleBarycentrics(x, l.v0, l.v1, l.v2);
    radiance *= emissiveTextureAt(l, float(b.x), float(b.y));
  }
  return LightSample{p, l.n, l.planeAt(p).v0, l.margin, radiance, pdf};
}

std::optional<LightSample> LightSampler::sampleTriangleByArea(size_t i, const Vec3& ref, Vec2 uPoint, float pmf) const {
  const Light& l = lights_[i];
  const TrianglePoint s = sampleTrianglePoint(l.v0, l.v1, l.v2, l.n, ref, uPoint, pmf, l.area, l.emission, l.twoSided);
  if (!s.valid()) return std::nullopt;
  const SpawnPlane plane = l.planeAt(s.p);
  const Spectrum radiance = l.textured != 0.0f ? s.radiance * emissiveTexture(l, uPoint) : s.radiance;
  return LightSample{s.p, l.n, plane.v0, l.margin, radiance, s.pdf};
}

std::optional<LightSample> LightSampler::sample(const Vec3& ref, float uChoice, Vec2 uPoint) const {
  if (empty()) return std::nullopt;
  const std::optional<Choice> c = chooseFrom(ref, uChoice);
  if (!c) return std::nullopt;
  const size_t i = c->light;
  const bool triangle = i < lights_.size();
  const bool bySolidAngle = triangle && LightSampler::bySolidAngle(lights_[i], ref);
  std::optional<LightSample> s = bySolidAngle ? sampleTriangleBySolidAngle(i, ref, uPoint, c->pmf)
                                 : triangle   ? sampleTriangleByArea(i, ref, uPoint, c->pmf)
                                              : sampleOther(i - lights_.size(), ref, uPoint, c->pmf);
  if (!s) return s;
  if (bySolidAngle) {
    // position()'s density of the point: the light by power, the point by area.
    const Light& l = lights_[i];
    const Vec3 toLight = s->p - ref;
    const float dist2 = glm::dot(toLight, toLight);
    const float cosLight = std::abs(glm::dot(l.n, toLight)) / std::sqrt(dist2);
    s->positionPdfRatio = pmfByPower(i) * dist2 / (cosLight * l.area) / s->pdf;
  } else if (usesTree()) {
    s->positionPdfRatio = pmfByPower(i) / c->pmf;
  }
  return s;
}

std::optional<LightSample> LightSampler::samplePositioned(const Vec3& ref, float uChoice, Vec2 uPoint) const {
  if (empty()) return std::nullopt;
  const size_t i = choose(uChoice);
  const float byPower = pmfByPower(i);
  std::optional<LightSample> s = i < lights_.size() ? sampleTriangleByArea(i, ref, uPoint, byPower)
                                                    : sampleOther(i - lights_.size(), ref, uPoint, byPower);
  if (!s) return std::nullopt;
  // The density sample() gives the same point from ref: its own choice of the light, and where it
  // takes the point by solid angle, 1 / Omega instead of the area's density.
  const float chosen = pmfFrom(ref, i);
  constexpr float kNever = std::numeric_limits<float>::infinity();
  s->positionPdfRatio = chosen > 0.0f ? byPower / chosen : kNever;  // the same point density, two choices
  if (i < lights_.size() && bySolidAngle(lights_[i], ref)) {
    const float sampled = solidAnglePdf(lights_[i], ref, chosen);
    s->positionPdfRatio = sampled > 0.0f ? s->pdf / sampled : kNever;
  }
  return s;
}

void LightSampler::sample(LightSampleLanes& lanes) const {
  if (empty()) {
    for (int& found : lanes.found) found = 0;
    return;
  }
  if (usesTree() || !others_.empty()) {
    sampleChosenLanes(lanes);
    return;
  }
  sampleTriangleLanes(lanes);
}

void LightSampler::sampleTriangleLanes(LightSampleLanes& lanes) const {
  // A lane not asked for computes on the first light (finite values) and stays not found.
  alignas(64) float dist2[kPacketWidth], cosLight[kPacketWidth], near[kPacketWidth];
  alignas(64) uint32_t chosen[kPacketWidth];
  if (lights_.size() <= SelectView::kLights) {
    sampleSelectedLanes(SelectView(lights_.data(), lights_.size()), uint32_t(lights_.size() - 1), fewCdf_, lanes,
                        chosen, dist2, cosLight);
  } else {
    for (int k = 0; k < kPacketWidth; ++k) chosen[k] = lanes.found[k] != 0 ? uint32_t(choose(lanes.uChoice[k])) : 0u;
    sampleGatheredLanes(GatherView<Light>(lights_.data()), chosen, lanes, dist2, cosLight);
  }
  nearLanes(lanes, chosen, near);
  for (int k = 0; k < kPacketWidth; ++k) {
    const TrianglePoint s{{}, {}, lanes.pdf[k], dist2[k], cosLight[k]};
    if (!s.valid() && near[k] == 0.0f) lanes.found[k] = 0;
  }
  finishTriangleLanes(lanes, chosen, nullptr, near);
}

void LightSampler::nearLanes(const LightSampleLanes& lanes, const uint32_t* chosen, float* near) const {
  if (reachLo_.x > reachHi_.x)  // no light's reach holds a surface
    std::fill(near, near + kPacketWidth, 0.0f);
  else
    markNearLanes(GatherView<Light>(lights_.data()), chosen, lanes, near);
}

void LightSampler::finishTriangleLanes(LightSampleLanes& lanes, const uint32_t* chosen, const float* pmf,
                                       const float* near) const {
  if (!hasTextured_ && std::all_of(near, near + kPacketWidth, [](float x) { return x == 0.0f; })) return;
  for (int k = 0; k < kPacketWidth; ++k) {
    if (lanes.found[k] == 0) continue;
    const Light& l = lights_[chosen[k]];
    const Vec2 uPoint(lanes.u0[k], lanes.u1[k]);
    if (near[k] != 0.0f) {
      const Vec3 ref(lanes.refx[k], lanes.refy[k], lanes.refz[k]);
      putLane(lanes, k, sampleTriangleBySolidAngle(chosen[k], ref, uPoint, pmf ? pmf[k] : l.pmf));
      continue;
    }
    if (l.textured == 0.0f) continue;
    // A textured emitter: its texture's value at the lane's point (sample()'s radiance).
    const Spectrum f = emissiveTexture(l, uPoint);
    lanes.rr[k] *= f.r, lanes.rg[k] *= f.g, lanes.rb[k] *= f.b;
  }
}

void LightSampler::sampleChosenLanes(LightSampleLanes& lanes) const {
  // Each lane chooses its light (with a tree, descending it from its own point: a loop of
  // branches, lane by lane); those that choose a triangle sample it in the lane loop with their
  // own pmf, the others one by one (sampleOther, what sample() does for them).
  alignas(64) uint32_t chosen[kPacketWidth];
  alignas(64) float pmf[kPacketWidth];
  size_t other[kPacketWidth];
  bool triangle[kPacketWidth], anyTriangle = false;
  for (int k = 0; k < kPacketWidth; ++k) {
    chosen[k] = 0, pmf[k] = 1.0f, other[k] = SIZE_MAX, triangle[k] = false;
    lanes.delta[k] = 0;
    lanes.reach[k] = 0.0f;
    if (lanes.found[k] == 0) continue;
    const std::optional<Choice> c = chooseFrom(Vec3(lanes.refx[k], lanes.refy[k], lanes.refz[k]), lanes.uChoice[k]);
    if (!c) {
      lanes.found[k] = 0;
      continue;
    }
    pmf[k] = c->pmf;
    triangle[k] = c->light < lights_.size();
    if (triangle[k])
      chosen[k] = uint32_t(c->light);
    else
      other[k] = c->light - lights_.size();
    anyTriangle |= triangle[k];
  }
  if (anyTriangle) {
    alignas(64) float dist2[kPacketWidth], cosLight[kPacketWidth], near[kPacketWidth];
    sampleGatheredLanesWithPmf(GatherView<Light>(lights_.data()), chosen, pmf, lanes, dist2, cosLight);
    nearLanes(lanes, chosen, near);
    // (The other lights' lanes computed on light 0 here; putLane below overwrites all they hold.)
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!triangle[k]) near[k] = 0.0f;
      const TrianglePoint s{{}, {}, lanes.pdf[k], dist2[k], cosLight[k]};
      if (triangle[k] && !s.valid() && near[k] == 0.0f) lanes.found[k] = 0;
    }
    finishTriangleLanes(lanes, chosen, pmf, near);
  }
  for (int k = 0; k < kPacketWidth; ++k)
    if (other[k] != SIZE_MAX)
      putLane(lanes, k,
              sampleOther(other[k], Vec3(lanes.refx[k], lanes.refy[k], lanes.refz[k]), Vec2(lanes.u0[k], lanes.u1[k]),
                          pmf[k]));
}

void LightSampler::putLane(LightSampleLanes& lanes, int k, const std::optional<LightSample>& s) {
  if (!s) {
    lanes.found[k] = 0;
    return;
  }
  lanes.px[k] = s->p.x, lanes.py[k] = s->p.y, lanes.pz[k] = s->p.z;
  lanes.nx[k] = s->n.x, lanes.ny[k] = s->n.y, lanes.nz[k] = s->n.z;
  lanes.v0x[k] = s->v0.x, lanes.v0y[k] = s->v0.y, lanes.v0z[k] = s->v0.z;
  lanes.margin[k] = s->margin;
  lanes.rr[k] = s->radiance.r, lanes.rg[k] = s->radiance.g, lanes.rb[k] = s->radiance.b;
  lanes.pdf[k] = s->pdf;
  lanes.delta[k] = s->delta ? 1 : 0;
  lanes.reach[k] = s->reach;
}

LightSampler::HitPdf LightSampler::pdfs(uint32_t triangle, const Vec3& ref, float distance, const Vec3& d) const {
  const int32_t i = lightOfTriangle_[triangle];
  if (i < 0) return {0.0f, 0.0f};
  const Light& light = lights_[i];
  const float cosLight = std::abs(glm::dot(caster_.triangles()[triangle].n, d));
  if (!(cosLight > 0.0f)) return {0.0f, 0.0f};
  const float byPower = light.pmf * distance * distance / (cosLight * light.area);
  if (bySolidAngle(light, ref))
    return {solidAnglePdf(light, ref, usesTree() ? pmfFrom(ref, size_t(i)) : light.pmf), byPower};
  if (!usesTree()) return {byPower, byPower};
  return {pmfFrom(ref, size_t(i)) * distance * distance / (cosLight * light.area), byPower};
}

Spectrum LightSampler::emitted(uint32_t triangle, const Vec3& d) const {
  const auto& t = caster_.triangles()[triangle];
  const Material& m = scene_.materials[t.material];
  if (!m.twoSidedEmission && glm::dot(t.n, d) >= 0.0f) return Spectrum(0.0f);  // seen from behind
  return m.emission;
}

}  // namespace lensfarm
