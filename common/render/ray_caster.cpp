#include "common/render/ray_caster.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/math/lanes.h"
#include "common/math/ray_offset.h"
#include "common/math/triangle.h"
#include "common/render/cutout.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {
void embreeError(void*, RTCError code, const char* message) {
  spdlog::error("embree error {}: {}", int(code), message ? message : "");
}

// The direction a missed ray is re-cast with (see intersect below).
Vec3 nudgedDirection(const Vec3& d) {
  const Frame frame = Frame::fromNormal(d);
  return glm::normalize(d + 1e-6f * (frame.t + 0.5f * frame.b));
}

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// The coplanar rule's test (docs/numerics.md, "Coplanar surfaces"): whether a ray from o in
// direction d starts in the plane of the triangle it hit, within the triangle's margin (the
// distance Embree's test resolves): then the hit is the ray leaving that surface, not meeting
// it. A camera on a wall's plane, or a ray leaving one of two coplanar surfaces, does not see
// the surface it starts in. The float test first (distance ~ t |cos|), the exact one in double
// only for hits that close.
// A scattered ray that starts within the margin but on the side it comes from (approaching the
// plane, not leaving it) meets the surface: that is a ray spawned from one wall near its edge
// with another, a hair inside the box; leaving the second wall put it outside, and it escaped
// (about 3 in 10^7 rays of a closed furnace, a lost path tail in one pixel in 65,536). Camera
// rays keep the rule either way: a camera standing in a plane is on one side of it only by
// rounding.
inline bool nearPlane(const Vec3& d, float t, const Vec3& n, float margin) {
  return t * std::abs(d.x * n.x + d.y * n.y + d.z * n.z) <= 4.0f * margin;
}
inline bool startsInPlane(const Vec3& o, const Vec3& d, RayKind kind, const Vec3& v0, const Vec3& n, float margin) {
  const DVec3 nd(n);
  const double s = glm::dot(nd, DVec3(o) - DVec3(v0));
  if (kind == RayKind::kScattered && s * glm::dot(nd, DVec3(d)) < 0.0) return false;  // approaching
  return std::abs(s) <= double(margin);
}

// The hit point at barycentrics (u, v): interpolating the vertices is far more accurate than
// o + t d far from the origin. Shared by the one-ray and packet forms, so both give the same bits.
inline Vec3 pointOnTriangle(const Vec3& v0, const Vec3& v1, const Vec3& v2, float u, float v) {
  return (1.0f - u - v) * v0 + u * v1 + v * v2;
}

// Embree's packet calls take a mask of the lanes in use, but on a machine without 16-wide kernels
// (no AVX-512) Embree traces a 16-wide packet through its ray-stream path, which ignores the mask,
// traces every lane whose tnear <= tfar and asserts that each such ray is finite. So a lane not in
// use is also switched off that way, with harmless finite values, whatever the packet held there
// (tests/render/ray_caster_isa_test.cpp renders with Embree's narrower kernels).
inline void loadPacket(const int (&valid)[kPacketWidth], const RayPacket& __restrict rays, const float* __restrict tFar,
                       RTCRay16& __restrict ray, unsigned mask, float scale) {
  // Branch-free, so the loop vectorises: a lane's bits are kept (valid -1) or replaced (valid 0).
  auto pick = [](int lane, float in, float off) {
    const uint32_t keep = uint32_t(lane);
    return std::bit_cast<float>((std::bit_cast<uint32_t>(in) & keep) | (std::bit_cast<uint32_t>(off) & ~keep));
  };
  for (int k = 0; k < kPacketWidth; ++k) {
    const int on = valid[k] != 0 ? -1 : 0;
    ray.org_x[k] = pick(on, rays.ox[k] * scale, 0.0f);
    ray.org_y[k] = pick(on, rays.oy[k] * scale, 0.0f);
    ray.org_z[k] = pick(on, rays.oz[k] * scale, 0.0f);
    ray.dir_x[k] = pick(on, rays.dx[k] * scale, 0.0f);
    ray.dir_y[k] = pick(on, rays.dy[k] * scale, 0.0f);
    ray.dir_z[k] = pick(on, rays.dz[k] * scale, 1.0f);
    ray.tnear[k] = pick(on, 0.0f, 1.0f);
    ray.tfar[k] = pick(on, tFar[k], 0.0f);
    ray.mask[k] = mask;
    ray.flags[k] = 0;
    ray.time[k] = 0.0f;
    ray.id[k] = unsigned(k);
  }
}

// The far end of an intersection ray: none.
alignas(64) constexpr float kNoFarEnd[kPacketWidth] = {kInfinity, kInfinity, kInfinity, kInfinity, kInfinity, kInfinity,
                                                       kInfinity, kInfinity, kInfinity, kInfinity, kInfinity, kInfinity,
                                                       kInfinity, kInfinity, kInfinity, kInfinity};

// surfaceHit for every lane of a packet, in one loop the compiler vectorises with gathers
// (math/lanes.h); the same operations as surfaceHit, so the same bits. Lanes without a hit
// (found 0) read triangle 0 of geometry 0 and keep finite values.
using Triangle = RayCaster::Triangle;
// nearPlane[k]: ~0u where lane k's hit passes startsInPlane's first (float) test.
// kInstances: whether the scene has instances (a scene without pays nothing for them).
template <bool kInstances>
LENSFARM_LANE_LOOPS void decodeHits(const uint32_t* __restrict geomOffset, GatherView<Triangle> tris,
                                    const RTCRayHit16& rh, RayCaster::PacketHits& __restrict out,
                                    uint32_t* __restrict nearPlane, float scale) {
  // Embree's arrays as plain pointers: GCC does not vectorise loads through RTCRayHit16's members.
  const uint32_t* __restrict geomID = rh.hit.geomID;
  const uint32_t* __restrict primID = rh.hit.primID;
  const uint32_t* __restrict instID = rh.hit.instID[0];
  const float* __restrict us = rh.hit.u, * __restrict vs = rh.hit.v, * __restrict tfar = rh.ray.tfar;
  const float* __restrict dx = rh.ray.dir_x, * __restrict dy = rh.ray.dir_y, * __restrict dz = rh.ray.dir_z;
  // Without branches, so the loop vectorises: a lane without a hit keeps no bit of Embree's output.
  auto keep = [](uint32_t mask, float x) { return std::bit_cast<float>(std::bit_cast<uint32_t>(x) & mask); };
  for (int k = 0; k < kPacketWidth; ++k) {
    const uint32_t hit = uint32_t(out.found[k]);
    // A lane that hit an instance reads triangle 0 here; RayCaster::intersect decodes it after.
    const uint32_t mesh = kInstances ? hit & (instID[k] == RTC_INVALID_GEOMETRY_ID ? ~0u : 0u) : hit;
    const uint32_t index = geomOffset[geomID[k] & mesh] + (primID[k] & mesh);
    const float u = keep(hit, us[k]), v = keep(hit, vs[k]);
    const Vec3 p = pointOnTriangle(tris.vec3(index, offsetof(Triangle, v0)), tris.vec3(index, offsetof(Triangle, v1)),
                                   tris.vec3(index, offsetof(Triangle, v2)), u, v);
    const Vec3 n = tris.vec3(index, offsetof(Triangle, n));
    const Vec3 v0 = tris.vec3(index, offsetof(Triangle, v0));
    out.triangle[k] = index;
    out.instance[k] = kNoInstance;
    out.b1[k] = u, out.b2[k] = v;
    out.material[k] = tris.u(index, offsetof(Triangle, material));
    out.t[k] = keep(hit, tfar[k]);
    out.px[k] = p.x, out.py[k] = p.y, out.pz[k] = p.z;
    out.nx[k] = n.x, out.ny[k] = n.y, out.nz[k] = n.z;
    out.v0x[k] = v0.x, out.v0y[k] = v0.y, out.v0z[k] = v0.z;
    out.margin[k] = tris.f(index, offsetof(Triangle, margin));
    const float along = out.t[k] * std::abs(dx[k] * n.x + dy[k] * n.y + dz[k] * n.z);
    // (The directions Embree was given are scale times the rays': embreeScale_.)
    nearPlane[k] = mesh & (along <= 4.0f * out.margin[k] * scale ? ~0u : 0u);
  }
}
}  // namespace

RayCaster::RayCaster(const Scene& scene) : source_(scene) {
  size_t triangleCount = 0, prototypeTriangleCount = 0;
  for (const TriangleMesh& mesh : scene.meshes) triangleCount += mesh.triangleCount();
  for (const TriangleMesh& mesh : scene.prototypes) prototypeTriangleCount += mesh.triangleCount();
  for (const MeshInstance& instance : scene.instances)
    if (instance.prototype >= scene.prototypes.size() || scene.prototypes[instance.prototype].triangleCount() == 0)
      throw std::runtime_error("instance \"" + instance.name + "\" places prototype " +
                               std::to_string(instance.prototype) + ", which does not exist or has no triangles");
  // (The scene loader refuses both cases with its own message; this guards scenes built in code.)
  if (triangleCount == 0 && scene.instances.empty()) throw std::runtime_error("the scene has no triangles");
  if (std::max(triangleCount, prototypeTriangleCount) > GatherView<Triangle>::kMaxRecords)  // indexed with 32 bits
    throw std::runtime_error("the scene has " + std::to_string(triangleCount + prototypeTriangleCount) +
                             " triangles; at most " + std::to_string(GatherView<Triangle>::kMaxRecords) +
                             " are supported");
  createDevice(scene.render.kernel.value_or(machineBestKernel()));
  chooseEmbreeScale(scene);
  const std::vector<std::vector<uint32_t>> precise = preciseTrianglesOf(scene);
  attachMeshes(scene, precise);
  attachInstances(scene);
  rtcCommitScene(scene_);
  if (geomOffset_.empty()) placeGeometry(0, 0, false);  // (the packet decoder reads entry 0 for every lane)
  buildTriangleTables(scene, precise, triangleCount, prototypeTriangleCount);
  computeInstanceMargins(scene);
  for (const auto& [lo, hi] : instanceBoxes(scene)) lo_ = glm::min(lo_, lo), hi_ = glm::max(hi_, hi);
}

void RayCaster::createDevice(TraceKernel kernel) {
  // Embree's kernels for different instruction sets round differently (util/trace_kernel.h): the
  // device is always told which, so the bits never depend on what Embree would pick by itself.
  // Embree quietly runs a narrower kernel than one the CPU lacks: refused here instead.
  std::string runs;
  if (!machineRuns(kernel, &runs))
    throw InputError("kernel", std::string("this machine cannot run Embree's ") + kernelName(kernel) +
                                   " traversal kernel (it runs " + runs + ")");
  const std::string config = embreeDeviceConfig(kernel);
  device_ = rtcNewDevice(config.c_str());
  if (!device_) throw std::runtime_error("cannot create an Embree device with configuration \"" + config + "\"");
  rtcSetDeviceErrorFunction(device_, embreeError, nullptr);
  rtcSetDeviceMemoryMonitorFunction(device_, embreeMemory, this);
  scene_ = rtcNewScene(device_);
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
}

void RayCaster::chooseEmbreeScale(const Scene& scene) {
  DVec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const TriangleMesh& mesh : scene.meshes)
    for (const Vec3& v : mesh.positions) lo = glm::min(lo, DVec3(v)), hi = glm::max(hi, DVec3(v));
  for (const auto& [a, b] : instanceBoxes(scene)) lo = glm::min(lo, a), hi = glm::max(hi, b);
  const double extent = lo.x <= hi.x ? largestAbs(hi - lo) : 0.0;
  if (extent > 0.0 && extent < kSmallScene) embreeScale_ = float(std::exp2(std::floor(-std::log2(extent))));
  if (extent > kLargeScene) embreeScale_ = float(std::exp2(std::floor(std::log2(kLargeScene / extent))));
}

void RayCaster::placeGeometry(unsigned id, uint32_t first, bool precise) {
  if (geomOffset_.size() <= id) geomOffset_.resize(id + 1, 0), isPrecise_.resize(id + 1, 0);
  geomOffset_[id] = first;
  isPrecise_[id] = precise ? 1 : 0;
}

void RayCaster::attachMeshes(const Scene& scene, const std::vector<std::vector<uint32_t>>& precise) {
  uint32_t first = 0;  // of each mesh, in triangles_
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const TriangleMesh& mesh = scene.meshes[m];
    RTCGeometry geom = meshGeometry(scene, mesh, embreeScale_, precise[m]);
    const unsigned mask = unsigned(RayKind::kScattered) | (mesh.visibleToCamera ? unsigned(RayKind::kCamera) : 0u);
    rtcSetGeometryMask(geom, mask);
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);  // the scene holds its own reference
    placeGeometry(id, first, false);
    meshFirst_.push_back(first);
    if (!precise[m].empty()) {
      for (const uint32_t tri : precise[m]) preciseTriangles_.push_back(first + tri);
      precise_.push_back(std::make_unique<PreciseTriangles>(scene, mesh, precise[m], embreeScale_, mask));
      RTCGeometry user = precise_.back()->geometry(device_);
      rtcCommitGeometry(user);
      placeGeometry(rtcAttachGeometry(scene_, user), first, true);
      rtcReleaseGeometry(user);
      spdlog::debug("mesh {}: {} triangles too large for Embree's float test are tested in double", m,
                    precise[m].size());
    }
    first += uint32_t(mesh.triangleCount());
  }
}

void RayCaster::attachInstances(const Scene& scene) {
  // Each prototype is a scene of its own, each use of it an instance geometry of the top scene.
  for (const TriangleMesh& mesh : scene.prototypes) {
    RTCScene child = rtcNewScene(device_);
    rtcSetSceneFlags(child, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(child, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geom = meshGeometry(scene, mesh, 1.0f);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(child, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(child);
    prototypeScenes_.push_back(child);
  }
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const MeshInstance& instance = scene.instances[k];
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(geom, prototypeScenes_[instance.prototype]);
    rtcSetGeometryTimeStepCount(geom, 1);
    // Scaled whole: object space to Embree's (embreeScale_ times render space).
    glm::mat4x3 placed = instance.toRender;
    for (int c = 0; c < 4; ++c) placed[c] *= embreeScale_;
    rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, &placed[0][0]);
    rtcSetGeometryMask(geom,
                       unsigned(RayKind::kScattered) | (instance.visibleToCamera ? unsigned(RayKind::kCamera) : 0u));
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);
    if (instanceOfGeometry_.size() <= id) instanceOfGeometry_.resize(id + 1, kNoInstance);
    instanceOfGeometry_[id] = uint32_t(k);
  }
}

void RayCaster::buildTriangleTables(const Scene& scene, const std::vector<std::vector<uint32_t>>& precise,
                                    size_t triangleCount, size_t prototypeTriangleCount) {
  // The triangle tables after the BVH: Embree's build memory is freed by then, so the two never
  // add up at the peak. Reserved whole, they are never reallocated while they grow.
  triangles_.reserve(std::max<size_t>(triangleCount, 1));
  for (size_t m = 0; m < scene.meshes.size(); ++m) addTriangles(scene.meshes[m], triangles_, precise[m]);
  for (const Triangle& t : triangles_)
    for (const Vec3& v : {t.v0, t.v1, t.v2}) lo_ = glm::min(lo_, DVec3(v)), hi_ = glm::max(hi_, DVec3(v));
  if (triangles_.empty()) {
    // A scene of instances alone: the packet decoder reads triangle 0 for lanes without a mesh
    // hit. A point at the camera, of a prototype's (never emitting) material; never hit.
    Triangle t{};
    t.n = Vec3(0.0f, 0.0f, 1.0f);
    t.material = scene.prototypes[scene.instances.front().prototype].materialIds.front();
    triangles_.push_back(t);
  }
  prototypeTriangles_.reserve(prototypeTriangleCount);
  for (const TriangleMesh& mesh : scene.prototypes) {
    prototypeOffset_.push_back(uint32_t(prototypeTriangles_.size()));
    addTriangles(mesh, prototypeTriangles_);
  }
}

void RayCaster::computeInstanceMargins(const Scene& scene) {
  // Per instance, what its transform adds to the spawn margin (instanceHit). Embree intersects
  // an instance in object space, the ray's origin moved there in float as A^-1 o - A^-1 t (A the
  // linear part, t the translation): near the instance, o ~ t, so the two terms cancel and the
  // rounding of each stays, about eps (|A^-1| |t|) per object axis (|.| elementwise), however
  // small the instance; Embree's float inverse adds about eps cond(A) |A^-1| |A| r (r the
  // prototype's extent), acting on o - t only. Bounded here with a factor 2 to spare.
  std::vector<double> extent;  // per prototype: its largest coordinate
  for (const TriangleMesh& mesh : scene.prototypes) {
    const auto [lo, hi] = boundsOf(mesh.positions);
    extent.push_back(std::max(largestAbs(DVec3(lo)), largestAbs(DVec3(hi))));
  }
  const auto absOf = [](glm::dmat3 m) {
    for (int c = 0; c < 3; ++c) m[c] = glm::abs(m[c]);
    return m;
  };
  const auto rowNorm = [](const glm::dmat3& m) {
    double n = 0.0;
    for (int r = 0; r < 3; ++r) n = std::max(n, std::abs(m[0][r]) + std::abs(m[1][r]) + std::abs(m[2][r]));
    return n;
  };
  for (const MeshInstance& instance : scene.instances) {
    const glm::dmat3 a(glm::mat3(instance.toRender));
    const glm::dmat3 inverse = glm::inverse(a);
    const DVec3 t = glm::abs(DVec3(instance.toRender[3]));
    const double cond = rowNorm(a) * rowNorm(inverse);
    const double eps = double(std::numeric_limits<float>::epsilon());
    const DVec3 r(extent[instance.prototype]);
    DVec3 error = 2.0 * eps * (2.0 * (absOf(inverse) * t) + (2.0 + cond) * (absOf(inverse) * (absOf(a) * r)));
    if (!isFinite(Spectrum(error))) error = DVec3(0.0);
    instanceMargins_.push_back({glm::transpose(glm::mat3(a)), Vec3(error)});
  }
}

// Embree reports every allocation (bytes > 0) and release (bytes < 0) on the device.
bool RayCaster::embreeMemory(void* caster, ssize_t bytes, bool) {
  auto* self = static_cast<RayCaster*>(caster);
  const int64_t now = self->embreeBytes_.fetch_add(int64_t(bytes)) + int64_t(bytes);
  int64_t peak = self->embreePeak_.load();
  while (now > peak && !self->embreePeak_.compare_exchange_weak(peak, now)) {
  }
  return true;  // never refuse: the memory budget is checked before the scene is built
}

RTCGeometry RayCaster::meshGeometry(const Scene& scene, const TriangleMesh& mesh, float scale,
                                    const std::vector<uint32_t>& precise) {
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), mesh.positions.size()));
  for (size_t k = 0; k < mesh.positions.size(); ++k)
    for (int c = 0; c < 3; ++c) vertices[3 * k + c] = mesh.positions[k][c] * scale;
  // The mesh's own indices, not a copy (the scene outlives the caster). Vertices are copied:
  // Embree reads a vertex buffer's last element with a 16-byte load, past a Vec3 array's end.
  if (mesh.indices.empty()) {
    rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), 0);
  } else if (!precise.empty()) {
    // A copy, the precise triangles made points (zero area: Embree's test never reports them),
    // so that every other triangle keeps its index.
    auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(uint32_t), mesh.triangleCount()));
    std::copy(mesh.indices.begin(), mesh.indices.end(), indices);
    for (const uint32_t tri : precise) indices[3 * tri + 1] = indices[3 * tri + 2] = indices[3 * tri];
  } else {
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, mesh.indices.data(), 0,
                               3 * sizeof(uint32_t), mesh.triangleCount());
  }
  if (meshCutsOut(scene, mesh)) {
    cutouts_.push_back(std::make_unique<CutoutMesh>(CutoutMesh{&scene, &mesh}));
    rtcSetGeometryUserData(geom, cutouts_.back().get());
    rtcSetGeometryIntersectFilterFunction(geom, cutoutFilter);
    rtcSetGeometryOccludedFilterFunction(geom, cutoutFilter);
  }
  return geom;
}

void RayCaster::addTriangles(const TriangleMesh& mesh, std::vector<Triangle>& into,
                             const std::vector<uint32_t>& precise) const {
  auto nextPrecise = precise.begin();
  for (size_t tri = 0; tri < mesh.triangleCount(); ++tri) {
    Triangle t;
    t.v0 = mesh.positions[mesh.indices[3 * tri]];
    t.v1 = mesh.positions[mesh.indices[3 * tri + 1]];
    t.v2 = mesh.positions[mesh.indices[3 * tri + 2]];
    if (triangleNormal(t.v0, t.v1, t.v2)) {
      const SpawnPlane plane = spawnPlaneOf(t.v0, t.v1, t.v2);
      t.n = plane.n, t.margin = plane.margin;
      if (nextPrecise != precise.end() && *nextPrecise == tri)
        t.margin = preciseMargin(t.v0, t.v1, t.v2), ++nextPrecise;
    } else {
      // The loader drops zero-area triangles; one built in code keeps finite values (Embree never hits it).
      t.n = Vec3(0.0f, 0.0f, 1.0f), t.margin = 0.0f;
    }
    t.material = mesh.materialIds[tri];
    into.push_back(t);
  }
}

// A hit on a mesh with a cut-out material is rejected where render/cutout.h says so: the ray
// goes on as if the surface were not there.
void RayCaster::cutoutFilter(const RTCFilterFunctionNArguments* args) {
  const auto* data = static_cast<const CutoutMesh*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    if (cutsAway(*data->scene, *data->mesh, RTCHitN_primID(args->hit, args->N, i), RTCHitN_u(args->hit, args->N, i),
                 RTCHitN_v(args->hit, args->N, i)))
      args->valid[i] = 0;
  }
}

RayCaster::~RayCaster() {
  if (scene_) rtcReleaseScene(scene_);
  for (RTCScene child : prototypeScenes_) rtcReleaseScene(child);
  if (device_) rtcReleaseDevice(device_);
}

std::optional<SurfaceHit> RayCaster::intersect(const Vec3& o, const Vec3& d, RayKind kind) const {
  if (recorder_) recorder_->record({o, d, std::numeric_limits<float>::infinity(), unsigned(kind)});
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = o.x * embreeScale_;
  rh.ray.org_y = o.y * embreeScale_;
  rh.ray.org_z = o.z * embreeScale_;
  rh.ray.dir_x = d.x * embreeScale_;
  rh.ray.dir_y = d.y * embreeScale_;
  rh.ray.dir_z = d.z * embreeScale_;
  rh.ray.tnear = 0.0f;  // origins are offset off their surface (math/ray_offset.h)
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.mask = unsigned(kind);
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
    // Embree's robust mode is watertight along edges but can let a ray aimed exactly at a shared
    // vertex slip between the triangles around it (embree#174, #188). A miss is therefore cast
    // once more with the direction turned slightly: a ray through a vertex then lands on
    // one of its triangles, and a ray into empty space misses again. Misses cost two rays.
    // (docs/numerics.md; NoRayEscapes* tests.)
    // Turned by about 1e-6 radians about an axis perpendicular to d: far more than the rounding
    // around a vertex, far less than anything a pixel could show.
    const Vec3 nudged = nudgedDirection(d);
    rh.ray.dir_x = nudged.x * embreeScale_;
    rh.ray.dir_y = nudged.y * embreeScale_;
    rh.ray.dir_z = nudged.z * embreeScale_;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  }

  SurfaceHit hit =
      rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID
          ? surfaceHit(rh.hit.geomID, rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar,
                       Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z))
          : instanceHit(instanceOfGeometry_[rh.hit.instID[0]], rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar);
  if (nearPlane(d, hit.t, hit.n, hit.margin) && startsInPlane(o, d, kind, hit.v0, hit.n, hit.margin))
    return leavePlane(o, d, kind, hit);
  return hit;
}

std::optional<SurfaceHit> RayCaster::leavePlane(const Vec3& o, const Vec3& d, RayKind kind,
                                                const SurfaceHit& hit) const {
  // From just off the plane on the side d points to (math/ray_offset.h); the distance keeps
  // counting from o. A ray can start in several coplanar surfaces: each is left in turn.
  const Vec3 from = spawnOrigin(o, hit.plane(), d);
  auto next = intersect(from, d, kind);
  if (next) next->t += glm::dot(from - o, d);
  return next;
}

SurfaceHit RayCaster::surfaceHit(unsigned geomID, unsigned primID, float u, float v, float t, const Vec3& ng) const {
  const size_t k = geomOffset_[geomID] + primID;
  const Triangle& tri = triangles_[k];
  SurfaceHit hit;
  hit.t = t;
  hit.p = pointOnTriangle(tri.v0, tri.v1, tri.v2, u, v);
  hit.n = tri.n;
  hit.v0 = tri.v0;
  hit.margin = tri.margin;
  hit.material = tri.material;
  hit.triangle = uint32_t(k);
  hit.b1 = u, hit.b2 = v;
  hit.instance = kNoInstance;
  // A precise triangle's point, from its own test; its spawn plane is anchored there, which the
  // float normal's tilt cannot move (its tilt over the triangle's size would be ulps of 1e10).
  if (isPrecise_[geomID]) hit.p = ng, hit.v0 = ng;
  return hit;
}

// The prototype's triangle placed by the instance's float matrix (the one Embree traced), its
// normal that of the placed triangle, turned for a mirroring transform so that the front stays
// the object's front; the spawn margin widened as the constructor explains.
SurfaceHit RayCaster::instanceHit(uint32_t instance, unsigned primID, float u, float v, float t) const {
  const MeshInstance& in = source_.instances[instance];
  const Triangle& o = prototypeTriangles_[prototypeOffset_[in.prototype] + primID];
  const Vec3 v0 = in.point(o.v0), v1 = in.point(o.v1), v2 = in.point(o.v2);
  SurfaceHit hit;
  hit.t = t;
  hit.p = pointOnTriangle(v0, v1, v2, u, v);
  hit.v0 = v0;
  // The margin: the placed triangle's own, plus the object-space test's (a distance d from the
  // object's plane is |A^T n| d from the placed one), plus the rounding of the origin in object
  // space (the constructor's bound, seen along n).
  const InstanceMargin& widen = instanceMargins_[instance];
  if (triangleNormal(v0, v1, v2)) {
    const SpawnPlane plane = spawnPlaneOf(v0, v1, v2);
    hit.n = in.mirrors ? -plane.n : plane.n;
    hit.margin = plane.margin;
  } else {
    // Too small to have a float normal as placed (the object's is transformed instead).
    const Vec3 n = in.normalMatrix * o.n;
    const float length = glm::length(n);
    hit.n = length > 0.0f && std::isfinite(length) ? n / length : o.n;
    hit.margin = 0.0f;
  }
  const Vec3 stretch = glm::abs(widen.linearT * hit.n);
  hit.margin += glm::length(stretch) * o.margin + glm::dot(stretch, widen.originError);
  hit.material = o.material;
  hit.triangle = primID;
  hit.b1 = u, hit.b2 = v;
  hit.instance = instance;
  return hit;
}

RayCaster::HitMesh RayCaster::hitMesh(const SurfaceHit& hit) const {
  if (hit.instance != kNoInstance) {
    const MeshInstance& in = source_.instances[hit.instance];
    return {&source_.prototypes[in.prototype], hit.triangle, &in};
  }
  const auto it = std::upper_bound(meshFirst_.begin(), meshFirst_.end(), hit.triangle);
  const uint32_t mesh = uint32_t(it - meshFirst_.begin()) - 1;
  return {&source_.meshes[mesh], hit.triangle - meshFirst_[mesh], nullptr};
}

bool RayCaster::occluded(const Vec3& o, const Vec3& d, float tFar, RayKind kind) const {
  if (recorder_) recorder_->record({o, d, tFar, 0u});
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = o.x * embreeScale_;
  ray.org_y = o.y * embreeScale_;
  ray.org_z = o.z * embreeScale_;
  ray.dir_x = d.x * embreeScale_;
  ray.dir_y = d.y * embreeScale_;
  ray.dir_z = d.z * embreeScale_;
  ray.tnear = 0.0f;
  ray.tfar = tFar;
  ray.mask = unsigned(kind);
  ray.flags = 0;
  ray.time = 0.0f;
  rtcOccluded1(scene_, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

// Kept whole: one pass over a packet's RTCRayHit16 and lane arrays, through both Embree calls and the decoding.
void RayCaster::intersect(const RayPacket& rays, RayKind kind, PacketHits& out) const {
  if (recorder_) recorder_->recordPacket(rays, unsigned(kind));
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  // Camera packets hold the samples of one or a few neighbouring sensor cells.
  if (kind == RayKind::kCamera) context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) RTCRayHit16 rh;
  loadPacket(rays.valid, rays, kNoFarEnd, rh.ray, unsigned(kind), embreeScale_);
  for (int k = 0; k < kPacketWidth; ++k) {
    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
  }
  rtcIntersect16(rays.valid, scene_, &context, &rh);

  // Misses are cast once more, slightly turned, exactly as the single-ray call does. The lanes
  // that hit are switched off for it, their distance kept aside (Embree leaves their hit alone).
  alignas(64) int retry[kPacketWidth];
  bool anyMiss = false;
  for (int k = 0; k < kPacketWidth; ++k) {
    retry[k] = rays.valid[k] != 0 && rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID ? -1 : 0;
    anyMiss |= retry[k] != 0;
  }
  if (anyMiss) {
    alignas(64) float tHit[kPacketWidth];
    for (int k = 0; k < kPacketWidth; ++k) {
      tHit[k] = rh.ray.tfar[k];
      if (retry[k]) {
        const Vec3 nudged = nudgedDirection(rays.direction(k));
        rh.ray.dir_x[k] = nudged.x * embreeScale_;
        rh.ray.dir_y[k] = nudged.y * embreeScale_;
        rh.ray.dir_z[k] = nudged.z * embreeScale_;
      } else {
        rh.ray.tnear[k] = 1.0f;
        rh.ray.tfar[k] = 0.0f;
      }
    }
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    rtcIntersect16(retry, scene_, &context, &rh);
    for (int k = 0; k < kPacketWidth; ++k)
      if (!retry[k]) rh.ray.tfar[k] = tHit[k];
  }

  for (int k = 0; k < kPacketWidth; ++k)
    out.found[k] = rays.valid[k] != 0 && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID ? -1 : 0;
  alignas(64) uint32_t near[kPacketWidth];
  if (prototypeScenes_.empty()) {
    decodeHits<false>(geomOffset_.data(), GatherView<Triangle>(triangles_.data()), rh, out, near, embreeScale_);
  } else {
    decodeHits<true>(geomOffset_.data(), GatherView<Triangle>(triangles_.data()), rh, out, near, embreeScale_);
    // Hits on instances, decoded one by one, the coplanar rule's first test with them.
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!out.found[k] || rh.hit.instID[0][k] == RTC_INVALID_GEOMETRY_ID) continue;
      out.set(k, instanceHit(instanceOfGeometry_[rh.hit.instID[0][k]], rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k],
                             rh.ray.tfar[k]));
      near[k] = nearPlane(rays.direction(k), out.t[k], Vec3(out.nx[k], out.ny[k], out.nz[k]), out.margin[k]) ? ~0u : 0u;
    }
  }

  // Hits on precise triangles carry their point (surfaceHit).
  if (!precise_.empty())
    for (int k = 0; k < kPacketWidth; ++k) {
      if (!out.found[k] || rh.hit.instID[0][k] != RTC_INVALID_GEOMETRY_ID || !isPrecise_[rh.hit.geomID[k]]) continue;
      out.px[k] = out.v0x[k] = rh.hit.Ng_x[k];
      out.py[k] = out.v0y[k] = rh.hit.Ng_y[k];
      out.pz[k] = out.v0z[k] = rh.hit.Ng_z[k];
    }

  // The coplanar rule, as the single-ray call applies it (rare: those lanes take that call).
  uint32_t anyNear = 0;
  for (int k = 0; k < kPacketWidth; ++k) anyNear |= near[k];
  if (!anyNear) return;
  for (int k = 0; k < kPacketWidth; ++k) {
    if (!near[k]) continue;
    const Vec3 o = rays.origin(k), d = rays.direction(k);
    if (!startsInPlane(o, d, kind, Vec3(out.v0x[k], out.v0y[k], out.v0z[k]), Vec3(out.nx[k], out.ny[k], out.nz[k]),
                       out.margin[k]))
      continue;
    const auto next = leavePlane(o, d, kind, out.hit(k));
    out.found[k] = next ? -1 : 0;
    if (next) out.set(k, *next);
  }
}

void RayCaster::occluded(const RayPacket& rays, bool (&occluded)[kPacketWidth]) const {
  if (recorder_) recorder_->recordPacket(rays, 0u);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  alignas(64) RTCRay16 ray;
  loadPacket(rays.valid, rays, rays.tFar, ray, unsigned(RayKind::kScattered), embreeScale_);
  rtcOccluded16(rays.valid, scene_, &context, &ray);
  for (int k = 0; k < kPacketWidth; ++k) occluded[k] = rays.valid[k] != 0 && ray.tfar[k] < 0.0f;
}

}  // namespace lensfarm
