#pragma once
// Ray casting against the scene's triangles with Embree 3.
//
// The Embree scene is built once per loaded scene and shared read-only by every thread. The
// Scene must outlive its caster, unchanged: Embree reads the meshes' index arrays in place.
// It is built with RTC_SCENE_FLAG_ROBUST (watertight edges; see docs/numerics.md).
// Ray masks implement `visible_to_camera`: camera rays carry kCameraRay and skip geometry that
// the camera must not see; every other ray sees everything.
// Cut-outs (glTF alphaMode MASK, material/material.h): meshes with such a material get Embree
// filter functions that reject a hit where the material's alpha is below its cutoff, for every
// ray (camera, scattered, shadow) alike; other meshes have none and pay nothing.
// Instances (scene/scene.h, MeshInstance): each prototype is an Embree scene of its own, each use
// an Embree instance of it. A hit on one is returned in render space like any other (its
// triangle transformed, its spawn margin widened for the transform's rounding, below); a scene
// without instances pays one test per packet for them.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "common/math/lanes.h"
#include "common/math/ray_offset.h"
#include "common/math/vec.h"
#include "common/render/precise_triangles.h"
#include "common/scene/scene.h"

namespace lensfarm {

// Help text for the programs that trace rays (lensfarm render, lensfarm-worker): the environment
// variable RayCaster reads.
inline constexpr const char* kEmbreeConfigHelp =
    "Environment: LENSFARM_EMBREE_CONFIG, Embree's device configuration for experts (e.g. threads=2); its isa= "
    "caps the traversal kernels this machine offers (isa=avx2: sse2 and avx2). A farm pins one kernel per job "
    "by itself (docs/farm.md \"Mixed machines\").";

enum class RayKind : unsigned { kCamera = 1u, kScattered = 2u };

inline constexpr uint32_t kNoInstance = UINT32_MAX;

// Up to kPacketWidth rays, structure of arrays (Embree's own packet layout). A lane is in use when
// valid[lane] is -1 and unused when it is 0 (Embree's convention). Every array is 64 bytes, so
// each starts on a 64-byte boundary, as Embree's packet calls require.
struct alignas(64) RayPacket {
  int valid[kPacketWidth];
  float ox[kPacketWidth], oy[kPacketWidth], oz[kPacketWidth];
  float dx[kPacketWidth], dy[kPacketWidth], dz[kPacketWidth];
  float tFar[kPacketWidth];  // occlusion rays: the segment's end; intersection rays: unused

  void clear() {
    for (int& v : valid) v = 0;
  }
  void set(int lane, const Vec3& o, const Vec3& d, float tfar = 0.0f) {
    valid[lane] = -1;
    ox[lane] = o.x, oy[lane] = o.y, oz[lane] = o.z;
    dx[lane] = d.x, dy[lane] = d.y, dz[lane] = d.z;
    tFar[lane] = tfar;
  }
  bool active(int lane) const { return valid[lane] != 0; }
  Vec3 origin(int lane) const { return Vec3(ox[lane], oy[lane], oz[lane]); }
  Vec3 direction(int lane) const { return Vec3(dx[lane], dy[lane], dz[lane]); }
};

// Every ray a caster is asked for, per thread in the order that thread cast them: the ray-casting
// limit benchmark (bench/ray_limit.cpp) records the integrator's rays and replays them through
// the same calls to time Embree alone. Off (a null pointer) everywhere else.
class RayRecorder {
 public:
  struct Ray {
    Vec3 origin, direction;
    float tFar;     // occlusion rays: the segment's end; intersection rays: +inf
    unsigned kind;  // RayKind for intersection rays; 0 for occlusion rays
  };
  virtual ~RayRecorder() = default;
  // Called concurrently from every render thread. `kind` is a RayKind for intersection packets
  // and 0 for occlusion packets.
  virtual void record(const Ray& ray) = 0;
  virtual void recordPacket(const RayPacket& rays, unsigned kind) = 0;
};

struct SurfaceHit {
  float t;  // distance along the (unit) ray direction
  Vec3 p;   // hit point, interpolated from the vertices
  Vec3 n;   // geometric unit normal, front side: cross(v1 - v0, v2 - v0)
  Vec3 v0;  // the rest of the triangle's SpawnPlane (math/ray_offset.h)
  float margin;
  uint32_t material;
  uint32_t triangle;  // index into RayCaster::triangles(), or for an instance its prototype's triangle
  float b1, b2;       // barycentrics of p: p = (1 - b1 - b2) v0 + b1 v1 + b2 v2 (Embree's u, v)
  uint32_t instance;  // index into Scene::instances, or kNoInstance

  SpawnPlane plane() const { return SpawnPlane{v0, n, margin}; }
};

class RayCaster {
 public:
  explicit RayCaster(const Scene& scene);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  std::optional<SurfaceHit> intersect(const Vec3& origin, const Vec3& direction, RayKind kind) const;
  // True if anything blocks the segment origin + t * direction, t in (0, tFar).
  // `kind`: kCamera tests what a camera ray would see (a light tracer's connection to the lens).
  bool occluded(const Vec3& origin, const Vec3& direction, float tFar, RayKind kind = RayKind::kScattered) const;

  // The same for the active lanes of a packet, with Embree's 16-wide kernels. Each lane gets the
  // hit the single-ray call gives for its ray (misses are re-cast the same way), as arrays over
  // the lanes, which the packet tracer's lane loops read (render/integrator.cpp). `kind` applies
  // to every lane; camera packets (the samples of neighbouring sensor cells) are cast with
  // Embree's coherent flag.
  struct PacketHits {
    alignas(64) int found[kPacketWidth];  // -1: the lane's ray hit; 0: it missed, or the lane is not in use
    // SurfaceHit's fields. Lanes without a hit hold finite values of triangle 0.
    alignas(64) uint32_t triangle[kPacketWidth], material[kPacketWidth];
    alignas(64) float t[kPacketWidth];
    alignas(64) float px[kPacketWidth], py[kPacketWidth], pz[kPacketWidth];
    alignas(64) float nx[kPacketWidth], ny[kPacketWidth], nz[kPacketWidth];
    alignas(64) float v0x[kPacketWidth], v0y[kPacketWidth], v0z[kPacketWidth];
    alignas(64) float margin[kPacketWidth];
    alignas(64) float b1[kPacketWidth], b2[kPacketWidth];
    alignas(64) uint32_t instance[kPacketWidth];

    SurfaceHit hit(int lane) const {
      return SurfaceHit{t[lane],
                        Vec3(px[lane], py[lane], pz[lane]),
                        Vec3(nx[lane], ny[lane], nz[lane]),
                        Vec3(v0x[lane], v0y[lane], v0z[lane]),
                        margin[lane],
                        material[lane],
                        triangle[lane],
                        b1[lane],
                        b2[lane],
                        instance[lane]};
    }
    void set(int lane, const SurfaceHit& h) {
      t[lane] = h.t;
      px[lane] = h.p.x, py[lane] = h.p.y, pz[lane] = h.p.z;
      nx[lane] = h.n.x, ny[lane] = h.n.y, nz[lane] = h.n.z;
      v0x[lane] = h.v0.x, v0y[lane] = h.v0.y, v0z[lane] = h.v0.z;
      margin[lane] = h.margin;
      material[lane] = h.material;
      triangle[lane] = h.triangle;
      b1[lane] = h.b1, b2[lane] = h.b2;
      instance[lane] = h.instance;
    }
  };
  void intersect(const RayPacket& rays, RayKind kind, PacketHits& hits) const;
  // occluded[lane] for each active lane (inactive lanes: false). Uses rays.tFar.
  void occluded(const RayPacket& rays, bool (&occluded)[kPacketWidth]) const;

  // All triangles of the scene's meshes (not its instances), concatenated in scene order.
  struct Triangle {
    Vec3 v0, v1, v2;
    Vec3 n;        // unit geometric normal
    float margin;  // with n and v0, the triangle's SpawnPlane (math/ray_offset.h)
    uint32_t material;

    SpawnPlane plane() const { return SpawnPlane{v0, n, margin}; }
  };
  const std::vector<Triangle>& triangles() const { return triangles_; }
  // Whether triangle k of triangles() is tested in double (render/precise_triangles.h): its
  // hits' spawn planes are anchored at the hit point.
  bool isPrecise(uint32_t k) const { return std::binary_search(preciseTriangles_.begin(), preciseTriangles_.end(), k); }
  // The triangles held in memory: the meshes' and the prototypes' (each once, however many
  // instances draw it).
  size_t storedTriangles() const { return triangles_.size() + prototypeTriangles_.size(); }
  // The mesh a hit is on, the triangle's index there, and the instance placing it (null for a
  // mesh of Scene::meshes, whose vertices are in render space already).
  struct HitMesh {
    const TriangleMesh* mesh;
    uint32_t index;
    const MeshInstance* instance;
  };
  HitMesh hitMesh(const SurfaceHit& hit) const;
  // The box of every surface in render space, instances included (as placed: their prototype's
  // box transformed), and of the camera at the origin.
  DVec3 boundsLo() const { return lo_; }
  DVec3 boundsHi() const { return hi_; }
  // The bytes Embree holds for this caster now (its BVHs, vertex copies and instances, as its
  // memory monitor reports them), and the most it held at once while building.
  int64_t embreeBytes() const { return embreeBytes_.load(); }
  int64_t embreePeakBytes() const { return embreePeak_.load(); }

  // Benchmarks only: an observer that sees every ray cast from now on (nullptr: none). It changes
  // nothing the caster computes, hence const; set it while no thread is tracing.
  void setRecorder(RayRecorder* recorder) const { recorder_ = recorder; }

 private:
  mutable RayRecorder* recorder_ = nullptr;
  const Scene& source_;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<Triangle> triangles_;  // all meshes, concatenated
  std::vector<uint32_t> meshFirst_;  // first triangle of each mesh, in triangles_
  // Per top-level Embree geometry: its mesh's first triangle (0 for an instance), and whether it
  // is a mesh's precise triangles (render/precise_triangles.h), whose hits carry their point.
  std::vector<uint32_t> geomOffset_;
  std::vector<uint8_t> isPrecise_;
  std::vector<std::unique_ptr<PreciseTriangles>> precise_;
  std::vector<uint32_t> preciseTriangles_;  // their indices in triangles_, ascending
  // Instances: the prototypes' triangles in object space, concatenated, and where each
  // prototype's start; per top-level Embree geometry, the instance it is (kNoInstance for a
  // mesh); per instance, the spawn margin's widening for its transform (instanceHit).
  std::vector<Triangle> prototypeTriangles_;
  std::vector<uint32_t> prototypeOffset_;
  std::vector<RTCScene> prototypeScenes_;
  std::vector<uint32_t> instanceOfGeometry_;
  struct InstanceMargin {
    glm::mat3 linearT;  // A^T, A the transform's linear part
    Vec3 originError;   // per object-space axis: how far rounding may move a ray's origin there
  };
  std::vector<InstanceMargin> instanceMargins_;
  DVec3 lo_{0.0}, hi_{0.0};
  // The scale of the scene as Embree sees it: a power of two that makes a scene smaller than
  // kSmallScene about one unit across, and one larger than kLargeScene that size (1 for every
  // other), applied to its vertices, instance transforms and every ray's origin and direction.
  // Embree's float tests multiply up to four lengths, which underflow in a scene a few 1e-10
  // across (a quad there shaded black) and overflow in one 1e14 across (a distance times an edge
  // squared: shadow rays passed through blockers, the image 10 % too bright); a power of two
  // scales every float exactly, so distances along a ray (its parameter t) and barycentrics come
  // back unchanged, and a scene of ordinary size keeps every bit.
  float embreeScale_ = 1.0f;
  static constexpr double kSmallScene = 1.0 / 1024.0;
  static constexpr double kLargeScene = 4294967296.0;  // 2^32
  std::atomic<int64_t> embreeBytes_{0}, embreePeak_{0};
  static bool embreeMemory(void* caster, ssize_t bytes, bool post);
  // The cut-out filters' data (render/cutout.h), one per mesh that has a cut-out material.
  struct CutoutMesh {
    const Scene* scene;
    const TriangleMesh* mesh;
  };
  std::vector<std::unique_ptr<CutoutMesh>> cutouts_;
  static void cutoutFilter(const RTCFilterFunctionNArguments* args);

  // The constructor's steps, in its order.

  // The Embree device for `kernel` (the scene's, else the machine's widest; util/trace_kernel.h)
  // and the top-level scene, robust and high quality.
  void createDevice(TraceKernel kernel);
  // embreeScale_ from the extent of the scene's meshes and placed instances.
  void chooseEmbreeScale(const Scene& scene);
  // Records Embree geometry `id`'s first triangle in triangles_ and whether it is precise.
  void placeGeometry(unsigned id, uint32_t first, bool precise);
  // The scene's meshes as top-level geometries, with the precise triangles (per mesh) as their own.
  void attachMeshes(const Scene& scene, const std::vector<std::vector<uint32_t>>& precise);
  // Each prototype as an Embree scene of its own, each instance as an instance geometry of the top scene.
  void attachInstances(const Scene& scene);
  // triangles_ (and the bounds of the meshes) and prototypeTriangles_, after the BVH is built.
  void buildTriangleTables(const Scene& scene, const std::vector<std::vector<uint32_t>>& precise, size_t triangleCount,
                           size_t prototypeTriangleCount);
  // instanceMargins_: per instance, the spawn margin's widening for the rounding of its transform.
  void computeInstanceMargins(const Scene& scene);

  // ng: the hit's Ng, which for a precise triangle holds the hit point.
  SurfaceHit surfaceHit(unsigned geomID, unsigned primID, float u, float v, float t, const Vec3& ng) const;
  // The hit on triangle primID of instance `instance`, in render space.
  SurfaceHit instanceHit(uint32_t instance, unsigned primID, float u, float v, float t) const;
  // Embree's geometry for a mesh's triangles, with the cut-out filter if its materials need it.
  // `scale`: embreeScale_ for the scene's meshes, 1 for prototypes (their instances carry it).
  // `precise`: the triangles Embree must not test (the precise geometry does), ascending.
  RTCGeometry meshGeometry(const Scene& scene, const TriangleMesh& mesh, float scale,
                           const std::vector<uint32_t>& precise = {});
  void addTriangles(const TriangleMesh& mesh, std::vector<Triangle>& into,
                    const std::vector<uint32_t>& precise = {}) const;
  // The hit after `hit`, for a ray that starts in hit's plane (the coplanar rule).
  std::optional<SurfaceHit> leavePlane(const Vec3& o, const Vec3& d, RayKind kind, const SurfaceHit& hit) const;
};

}  // namespace lensfarm
