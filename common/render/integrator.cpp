#include "common/render/integrator.h"

#include <algorithm>
#include <cmath>

#include "common/math/lanes.h"
#include "common/math/ray_offset.h"
#include "common/math/sampling.h"
#include "common/render/path_vertex.h"
#include "common/render/shading_point.h"

namespace lensfarm {

using namespace path_vertex;

namespace {
// tracePath, its vertices guided by `guide` (null: none) and recorded by `recorder` (null: none).
template <bool kNee, bool kGeneral>
Spectrum traceOnePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats,
                      const GuidingField* guide, GuidingRecorder* recorder) {
  PathState path(cameraRay);
  path.guide = guide;
  path.recorder = recorder;
  ShadowQuery shadow;
  ++stats.paths;
  const int segments = pathSegmentLimit(rs.settings().maxBounces);
  for (int segment = 0; segment < segments; ++segment) {
    ++stats.rays;
    const auto hit =
        rs.caster().intersect(path.origin, path.direction, segment == 0 ? RayKind::kCamera : RayKind::kScattered);
    if (!hit) {
      if (rs.hasEscapeLights()) addEscapedLight<kNee>(rs, path);
      break;
    }
    const VertexOutcome outcome = shadeVertex<kNee, kGeneral>(rs, rng, segment, *hit, path, shadow);
    if (rs.lightTracing())
      path.lightTraced = stillLightTraced(rs, segment, hit->material, path.lightTraced, path.lastSpecular);
    if (outcome.castShadow) {
      ++stats.rays;
      if (!rs.caster().occluded(shadow.from, shadow.direction, shadow.tFar)) path.radiance += shadow.contribution;
    }
    if (recorder) recorder->settle(path.radiance);
    if (!outcome.continues) break;
    if (segment + 1 == segments) ++stats.truncated;
  }
  if (path.hitLight) ++stats.lightHits;
  return path.radiance;
}
}  // namespace

template <bool kNee, bool kGeneral>
Spectrum tracePath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng, PathStats& stats) {
  return traceOnePath<kNee, kGeneral>(rs, cameraRay, rng, stats, rs.guide(), nullptr);
}

Spectrum traceTrainingPath(const RenderScene& rs, const CameraRay& cameraRay, const SampleStream& rng,
                           const GuidingField* guide, GuidingRecorder& recorder, PathStats& stats) {
  recorder.pending.clear();
  const Spectrum radiance = rs.effects().lightSampling
                                ? traceOnePath<true, true>(rs, cameraRay, rng, stats, guide, &recorder)
                                : traceOnePath<false, true>(rs, cameraRay, rng, stats, guide, &recorder);
  return radiance;
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
  alignas(64) int lastSpecular[kPacketWidth];                              // 1 or 0 (an int, so lane loops can set it)
  alignas(64) float vx[kPacketWidth], vy[kPacketWidth], vz[kPacketWidth];  // PathState::vertex
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
      vx[k] = vy[k] = vz[k] = 0.0f;
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
    path.vertex = Vec3(vx[k], vy[k], vz[k]);
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
    vx[k] = path.vertex.x, vy[k] = path.vertex.y, vz[k] = path.vertex.z;
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
  alignas(64) float misOn[kPacketWidth];      // 1: the light sample takes the power heuristic's weight; 0: weight 1
  alignas(64) uint32_t guided[kPacketWidth];  // ~0u: a material path guiding guides (RenderScene::guided)
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
    const Vec3 from =
        spawnOrigin(p, Vec3(h.v0x[k], h.v0y[k], h.v0z[k]), Vec3(h.nx[k], h.ny[k], h.nz[k]), h.margin[k], wi);
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

// The lanes whose vertex is on a material the lane loops shade with its PrincipledModel record
// (RenderScene::laneModels: glTF's metallic-roughness without textures). The Lambertian loops run
// for them too; these loops then put the model's values in their place (the light sample's f and
// weight, the scattered direction, its weight and density), with the operations of shadeVertex's
// Bsdf calls (material/principled_model.h), in the same order.
struct GlossyLanes {
  alignas(64) uint32_t on[kPacketWidth];      // ~0u: a glossy lane
  alignas(64) uint32_t shaded[kPacketWidth];  // ~0u: its shading normal is per point (rule 2 of shading_point.h)
  // The shading normal, on wo's side (the geometric one is DiffuseLanes' n).
  alignas(64) float snx[kPacketWidth], sny[kPacketWidth], snz[kPacketWidth];
  alignas(64) float uLobe[kPacketWidth];
  // Steps between the loops: wo and wi in the shading frame, the model's f cos and density there,
  // 1 where wi lies below the surface or the shading normal (rule 2 of shading_point.h).
  alignas(64) float wox[kPacketWidth], woy[kPacketWidth], woz[kPacketWidth];
  alignas(64) float wix[kPacketWidth], wiy[kPacketWidth], wiz[kPacketWidth];
  alignas(64) float fr[kPacketWidth], fg[kPacketWidth], fb[kPacketWidth], pdf[kPacketWidth];
  alignas(64) float below[kPacketWidth];
};

// What each lane's vertex does, as masks over the lanes (~0u or 0): the decisions shadeVertex
// makes before its light sample, for every lane at once.
struct VertexLanes {
  // A model the lane loops do not shade, or an emitter: the one-path code runs first.
  alignas(64) uint32_t special[kPacketWidth];
  // A Lambertian or glossy (GlossyLanes) vertex within the bounce limit: the lane loops.
  alignas(64) uint32_t diffuse[kPacketWidth];
};
struct ClassifyRules {
  int maxBounces;
  uint32_t generalMaterials;  // ~0u where materials beyond Lambertian are compiled in (kGeneral)
  uint32_t nee;               // ~0u with next-event estimation
  uint32_t mis;               // ~0u with NEE + MIS
  uint32_t lastBounceEnds;    // ~0u with NEE where lastBounceCanEndPaths (isLastBounce)
};

LENSFARM_LANE_LOOPS void classifyVertices(const RayCaster::PacketHits& __restrict h, const PathLanes& __restrict path,
                                          GatherView<RenderScene::MaterialRecord> materials, ClassifyRules rules,
                                          VertexLanes& __restrict out, DiffuseLanes& __restrict v,
                                          GlossyLanes& __restrict g, LightSampleLanes& __restrict ls,
                                          int* __restrict goes) {
  using Record = RenderScene::MaterialRecord;
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t hit = uint32_t(h.found[k]), m = h.material[k];
    const uint32_t general = materials.u(m, offsetof(Record, general)) & rules.generalMaterials;
    const uint32_t emissive = materials.u(m, offsetof(Record, emissive));
    const uint32_t reflects = materials.u(m, offsetof(Record, reflects));
    const uint32_t glossy = materials.u(m, offsetof(Record, glossy)) & rules.generalMaterials;
    const uint32_t withinLimit = path.bounces[k] < rules.maxBounces ? ~0u : 0u;
    const uint32_t diffuse = hit & (~general | glossy) & reflects & withinLimit;
    const uint32_t lastBounce = (path.bounces[k] + 1 >= rules.maxBounces ? ~0u : 0u) & rules.lastBounceEnds;
    out.special[k] = hit & ((general & ~glossy) | emissive);
    out.diffuse[k] = diffuse;
    g.on[k] = diffuse & glossy;
    g.shaded[k] = diffuse & glossy & materials.u(m, offsetof(Record, shaded));
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
    rays.ox[k] = on ? v.ox[k] : rays.ox[k], rays.oy[k] = on ? v.oy[k] : rays.oy[k],
    rays.oz[k] = on ? v.oz[k] : rays.oz[k];
    rays.dx[k] = on ? v.dx[k] : rays.dx[k], rays.dy[k] = on ? v.dy[k] : rays.dy[k],
    rays.dz[k] = on ? v.dz[k] : rays.dz[k];
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

// Path guiding in the lanes (render/path_guiding.h): each guided lane that scatters on looks up
// its region (one by one: a tree walk); where one guides, the lane's light sample weight and its
// scattered direction are redone after the Lambertian loops, as shadeVertex's guided vertex does
// them: the mixture of the field and the cosine lobe, with the same formulas in the same order.
bool findGuidedRegions(const GuidingField& guide, const RayCaster::PacketHits& h, const DiffuseLanes& v,
                       const int* goes, int (&region)[kPacketWidth]) {
  bool any = false;
  for (int k = 0; k < kPacketWidth; ++k) {
    region[k] = v.guided[k] && goes[k] ? guide.regionAt(Vec3(h.px[k], h.py[k], h.pz[k])) : -1;
    any |= region[k] >= 0;
  }
  return any;
}

// The light sample's MIS weight against the mixture's density (prepareShadowRays' with it).
void guidedLightSamples(const GuidingField& guide, const int (&region)[kPacketWidth], const RayCaster::PacketHits& h,
                        const PathLanes& path, DiffuseLanes& v, const LightSampleLanes& ls) {
  for (int k = 0; k < kPacketWidth; ++k) {
    if (region[k] < 0 || !ls.found[k] || v.misOn[k] == 0.0f) continue;
    const Vec3 p(h.px[k], h.py[k], h.pz[k]), lightPoint(ls.px[k], ls.py[k], ls.pz[k]);
    const Vec3 n(v.nx[k], v.ny[k], v.nz[k]);
    const Vec3 wi = glm::normalize(lightPoint - p);
    const Spectrum f = lambertianEvalCos(Spectrum(v.ar[k], v.ag[k], v.ab[k]), n, wi);
    const float weight = powerHeuristic(ls.pdf[k], guidedPdf(guide.pdf(region[k], wi), lambertianPdf(n, wi)));
    const Spectrum c = Spectrum(path.tr[k], path.tg[k], path.tb[k]) * f * Spectrum(ls.rr[k], ls.rg[k], ls.rb[k]) *
                       (weight / ls.pdf[k]);
    v.cr[k] = c.r, v.cg[k] = c.g, v.cb[k] = c.b;
  }
}

// The scattered direction from the mixture (sampleGuided): its weight f cos / p in place of the
// albedo, its density, cosTheta 1 where it exists and 0 where it does not (the path ends).
void guidedDirections(const GuidingField& guide, const int (&region)[kPacketWidth], const PathPacket& packet,
                      uint32_t segmentBase, const RayCaster::PacketHits& h, DiffuseLanes& v) {
  for (int k = 0; k < kPacketWidth; ++k) {
    if (region[k] < 0) continue;
    const Vec3 n(v.nx[k], v.ny[k], v.nz[k]);
    const bool fromField = packet.rng[k].get1D(segmentBase + dims::kMaterialLobe) < kGuidedShare;
    const Vec3 wi = fromField ? guide.sample(region[k], Vec2(v.u0[k], v.u1[k])) : Vec3(v.dx[k], v.dy[k], v.dz[k]);
    const float p = guidedPdf(guide.pdf(region[k], wi), lambertianPdf(n, wi));
    const Spectrum f = lambertianEvalCos(Spectrum(v.ar[k], v.ag[k], v.ab[k]), n, wi);
    const bool exists = (fromField || v.cosTheta[k] > 0.0f) && p > 0.0f && !isBlack(f);
    const Spectrum weight = f / p;
    const Vec3 o = spawnOrigin(Vec3(h.px[k], h.py[k], h.pz[k]), Vec3(h.v0x[k], h.v0y[k], h.v0z[k]),
                               Vec3(h.nx[k], h.ny[k], h.nz[k]), h.margin[k], wi);
    v.ar[k] = weight.r, v.ag[k] = weight.g, v.ab[k] = weight.b;
    v.cosTheta[k] = exists ? 1.0f : 0.0f;
    v.pdf[k] = p;
    v.ox[k] = o.x, v.oy[k] = o.y, v.oz[k] = o.z;
    v.dx[k] = wi.x, v.dy[k] = wi.y, v.dz[k] = wi.z;
  }
}

[[gnu::always_inline]] inline PrincipledModel gatherModel(GatherView<PrincipledModel> models, uint32_t m) {
  return PrincipledModel{
      models.f(m, offsetof(PrincipledModel, baseR)),        models.f(m, offsetof(PrincipledModel, baseG)),
      models.f(m, offsetof(PrincipledModel, baseB)),        models.f(m, offsetof(PrincipledModel, metallic)),
      models.f(m, offsetof(PrincipledModel, transmission)), models.f(m, offsetof(PrincipledModel, specular)),
      models.f(m, offsetof(PrincipledModel, f0)),           models.f(m, offsetof(PrincipledModel, alpha)),
      models.f(m, offsetof(PrincipledModel, colour)),       models.f(m, offsetof(PrincipledModel, straight))};
}

// The glossy lanes' directions in their shading frames (Frame::fromNormal of the shading normal):
// wo, and wi towards the light point (glossyLightSamples) or as sampled (glossyDirections).
LENSFARM_LANE_LOOPS void toShadingFrames(const RayCaster::PacketHits& __restrict h, const RayPacket& __restrict rays,
                                         const DiffuseLanes& __restrict v, const LightSampleLanes& __restrict ls,
                                         GlossyLanes& __restrict g) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec3 p(h.px[k], h.py[k], h.pz[k]), lightPoint(ls.px[k], ls.py[k], ls.pz[k]);
    const Vec3 wi = glm::normalize(lightPoint - p);
    const Frame frame = Frame::fromNormal(Vec3(g.snx[k], g.sny[k], g.snz[k]));
    const Vec3 wo = frame.toLocal(-Vec3(rays.dx[k], rays.dy[k], rays.dz[k])), wiLocal = frame.toLocal(wi);
    g.wox[k] = wo.x, g.woy[k] = wo.y, g.woz[k] = wo.z;
    g.wix[k] = wiLocal.x, g.wiy[k] = wiLocal.y, g.wiz[k] = wiLocal.z;
    g.below[k] =
        (g.shaded[k] != 0) & !scattersTo(wi, Vec3(v.nx[k], v.ny[k], v.nz[k]), Vec3(g.snx[k], g.sny[k], g.snz[k]))
            ? 1.0f
            : 0.0f;
  }
}

// The model's f cos (fr, fg, fb) and density (pdf) for each lane's local wo and wi. (Loops of
// their own: GCC vectorises each, but not all of a vertex's steps in one.)
LENSFARM_LANE_LOOPS void evaluateModels(const RayCaster::PacketHits& __restrict h, GatherView<PrincipledModel> models,
                                        GlossyLanes& __restrict g) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const PrincipledModel m = gatherModel(models, h.material[k]);
    const Spectrum f = m.evalLocal(Vec3(g.wox[k], g.woy[k], g.woz[k]), Vec3(g.wix[k], g.wiy[k], g.wiz[k]));
    g.fr[k] = f.r, g.fg[k] = f.g, g.fb[k] = f.b;
  }
  for (int k = 0; k < kPacketWidth; ++k) {
    const PrincipledModel m = gatherModel(models, h.material[k]);
    g.pdf[k] = m.pdfLocal(Vec3(g.wox[k], g.woy[k], g.woz[k]), Vec3(g.wix[k], g.wiy[k], g.wiz[k]));
  }
}

// The light sample of every glossy lane: f and the MIS weight of the model (prepareShadowRays'
// Lambertian ones replaced).
LENSFARM_LANE_LOOPS void glossyLightSamples(const PathLanes& __restrict path, const GlossyLanes& __restrict g,
                                            DiffuseLanes& __restrict v, const LightSampleLanes& __restrict ls) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Spectrum f = g.below[k] != 0.0f ? Spectrum(0.0f) : Spectrum(g.fr[k], g.fg[k], g.fb[k]);
    const float weight = v.misOn[k] != 0.0f ? powerHeuristic(ls.pdf[k], g.pdf[k]) : 1.0f;
    const Spectrum c = Spectrum(path.tr[k], path.tg[k], path.tb[k]) * f * Spectrum(ls.rr[k], ls.rg[k], ls.rb[k]) *
                       (weight / ls.pdf[k]);
    const bool on = g.on[k] != 0;
    v.fr[k] = on ? f.r : v.fr[k], v.fg[k] = on ? f.g : v.fg[k], v.fb[k] = on ? f.b : v.fb[k];
    v.cr[k] = on ? c.r : v.cr[k], v.cg[k] = on ? c.g : v.cg[k], v.cb[k] = on ? c.b : v.cb[k];
  }
}

// Each glossy lane's sampled direction in its shading frame (PrincipledBsdf::sample's opaque form).
LENSFARM_LANE_LOOPS void sampleModels(const RayCaster::PacketHits& __restrict h, const RayPacket& __restrict rays,
                                      GatherView<PrincipledModel> models, const DiffuseLanes& __restrict v,
                                      GlossyLanes& __restrict g) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Frame frame = Frame::fromNormal(Vec3(g.snx[k], g.sny[k], g.snz[k]));
    const Vec3 wo = frame.toLocal(-Vec3(rays.dx[k], rays.dy[k], rays.dz[k]));
    const PrincipledModel m = gatherModel(models, h.material[k]);
    const Vec3 wi = m.sampleLocal(wo, m.lobes(wo.z), g.uLobe[k], Vec2(v.u0[k], v.u1[k]));
    g.wox[k] = wo.x, g.woy[k] = wo.y, g.woz[k] = wo.z;
    g.wix[k] = wi.x, g.wiy[k] = wi.y, g.wiz[k] = wi.z;
  }
}

// The scattered ray of every glossy lane: its weight f / pdf in place of the albedo, its density,
// and cosTheta 1 where it exists, 0 where the sample is absorbed (scatterDiffuse then ends the path).
LENSFARM_LANE_LOOPS void glossyDirections(const RayCaster::PacketHits& __restrict h, const GlossyLanes& __restrict g,
                                          DiffuseLanes& __restrict v) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec3 n(g.snx[k], g.sny[k], g.snz[k]);
    const Vec3 wi = Frame::fromNormal(n).toWorld(Vec3(g.wix[k], g.wiy[k], g.wiz[k]));
    const Spectrum f(g.fr[k], g.fg[k], g.fb[k]);
    const Spectrum weight = f / g.pdf[k];
    const bool lit = !isBlack(f);
    const bool leaves = (g.shaded[k] == 0) | scattersTo(wi, Vec3(v.nx[k], v.ny[k], v.nz[k]), n);
    const bool exists = (g.woz[k] > 0.0f) & (g.pdf[k] > 0.0f) & lit & leaves;
    const Vec3 o = spawnOrigin(Vec3(h.px[k], h.py[k], h.pz[k]), Vec3(h.v0x[k], h.v0y[k], h.v0z[k]),
                               Vec3(h.nx[k], h.ny[k], h.nz[k]), h.margin[k], wi);
    const bool on = g.on[k] != 0;
    v.cosTheta[k] = on ? (exists ? 1.0f : 0.0f) : v.cosTheta[k];
    v.pdf[k] = on ? g.pdf[k] : v.pdf[k];
    v.ar[k] = on ? weight.r : v.ar[k], v.ag[k] = on ? weight.g : v.ag[k], v.ab[k] = on ? weight.b : v.ab[k];
    v.ox[k] = on ? o.x : v.ox[k], v.oy[k] = on ? o.y : v.oy[k], v.oz[k] = on ? o.z : v.oz[k];
    v.dx[k] = on ? wi.x : v.dx[k], v.dy[k] = on ? wi.y : v.dy[k], v.dz[k] = on ? wi.z : v.dz[k];
  }
}
}  // namespace

// Kept whole: the lane loops share per-lane arrays across stages; one function lets the compiler keep them local.
template <bool kNee, bool kGeneral>
void tracePacket(const RenderScene& rs, const PathPacket& packet, Spectrum (&radiance)[kPacketWidth],
                 PathStats& stats) {
  const RenderSettings& settings = rs.settings();
  const GuidingField* guide = rs.guide();
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
  GlossyLanes glossy{};
  LightSampleLanes lights{};
  const SampleStream::LaneKeys keys = SampleStream::keysOf(packet.rng);
  const GatherView<RenderScene::MaterialRecord> materials(rs.materialRecords().data());
  const GatherView<PrincipledModel> models(rs.laneModels().data());
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
    classifyVertices(hits, paths, materials, rules, vertices, v, glossy, lights, goes);
    // (The guided lanes are found here, not in the loop above: a scene without guiding pays no gather.)
    if (guide)
      for (int k = 0; k < kPacketWidth; ++k)
        v.guided[k] = vertices.diffuse[k] ? rs.materialRecords()[hits.material[k]].guided : 0u;
    alignas(64) int generalGoes[kPacketWidth] = {};
    bool generalShadow[kPacketWidth] = {};
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!vertices.special[k]) continue;
      const Material& material = rs.material(hits.material[k]);
      PathState path = paths.get(k, rays);
      path.guide = rs.guide();
      const SurfaceHit hit = hits.hit(k);
      if (kGeneral && material.reflects() && !vertices.diffuse[k] &&
          (!material.isLambertian() || rs.shaded(hits.material[k]) || rs.guided(material))) {
        const VertexOutcome outcome =
            shadeVertex<kNee, kGeneral>(rs, packet.rng[k], segment, hit, path, generalShadows[k]);
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

    bool anyDiffuse = false, anyGlossy = false;
    for (int k = 0; k < kPacketWidth; ++k) anyDiffuse |= vertices.diffuse[k] != 0, anyGlossy |= glossy.on[k] != 0;
    if (anyDiffuse) {
      // The lane loops, then each diffuse lane's path goes on along its scattered ray or ends.
      orientNormals(hits, rays, v, lights);
      int region[kPacketWidth];
      const bool anyGuided = guide && findGuidedRegions(*guide, hits, v, goes, region);
      if (kGeneral && anyGlossy) {
        // The glossy lanes' lobe choice and shading normals (per point, one by one, where the
        // material's mesh has vertex normals: shadingPoint, as shadeVertex).
        SampleStream::values1D(packet.rng, keys, packet.count, segmentBase + dims::kMaterialLobe, glossy.uLobe);
        for (int k = 0; k < kPacketWidth; ++k) {
          Vec3 n(v.nx[k], v.ny[k], v.nz[k]);
          if (glossy.shaded[k]) {
            const SurfaceHit hit = hits.hit(k);
            const Vec3 wo = -rays.direction(k);
            n = shadingPoint(rs, hit, wo, n, glm::dot(hit.n, wo) >= 0.0f).n;
          }
          glossy.snx[k] = n.x, glossy.sny[k] = n.y, glossy.snz[k] = n.z;
        }
      }
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
        if (kGeneral && anyGlossy) {
          toShadingFrames(hits, rays, v, lights, glossy);
          evaluateModels(hits, models, glossy);
          glossyLightSamples(paths, glossy, v, lights);
        }
        if (anyGuided) guidedLightSamples(*guide, region, hits, paths, v, lights);
        for (int k = 0; k < kPacketWidth; ++k)
          shadowRays.valid[k] = lights.found[k] != 0 && !isBlack(Spectrum(lights.rr[k], lights.rg[k], lights.rb[k])) &&
                                        !isBlack(Spectrum(v.fr[k], v.fg[k], v.fb[k]))
                                    ? -1
                                    : 0;
      }
      sampleDirections(hits, v);
      if (kGeneral && anyGlossy) {
        sampleModels(hits, rays, models, v, glossy);
        evaluateModels(hits, models, glossy);
        glossyDirections(hits, glossy, v);
      }
      if (anyGuided) guidedDirections(*guide, region, packet, segmentBase, hits, v);
      scatterDiffuse(v, goes, paths);
      // The vertex the light the next ray reaches is weighed from (its light sample's choice and
      // density depend on it: a light tree, sampling by solid angle near a light).
      for (int k = 0; k < kPacketWidth; ++k)
        if (goes[k]) paths.vx[k] = hits.px[k], paths.vy[k] = hits.py[k], paths.vz[k] = hits.pz[k];
      if (settings.roulette != RouletteRule::kOff)
        for (int k = 0; k < kPacketWidth; ++k) {
          if (!goes[k]) continue;
          Spectrum throughput(paths.tr[k], paths.tg[k], paths.tb[k]);
          if (!survivesRoulette(settings, packet.rng[k], segmentBase, paths.bounces[k], paths.etaScale[k],
                                throughput)) {
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

#define LENSFARM_INSTANTIATE(NEE, SPECULAR)                                                                          \
  template Spectrum tracePath<NEE, SPECULAR>(const RenderScene&, const CameraRay&, const SampleStream&, PathStats&); \
  template void tracePacket<NEE, SPECULAR>(const RenderScene&, const PathPacket&, Spectrum(&)[kPacketWidth],         \
                                           PathStats&);
LENSFARM_INSTANTIATE(false, false)
LENSFARM_INSTANTIATE(false, true)
LENSFARM_INSTANTIATE(true, false)
LENSFARM_INSTANTIATE(true, true)
#undef LENSFARM_INSTANTIATE

}  // namespace lensfarm
