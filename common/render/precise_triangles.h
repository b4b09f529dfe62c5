#pragma once
// Triangles too large for Embree's float test, intersected in double (docs/numerics.md, "Scale").
//
// Embree's robust test translates a triangle's vertices to the ray origin in float, so the side
// of the plane it reports is uncertain by a few ulps of the triangle's size, and the spawn
// margin must cover that (math/ray_offset.h): about 4e3 for a ground quad 1e10 across. Every
// shadow ray from such a floor started 4e3 above it, beyond a lamp 2 above, and the floor came
// out black. Such triangles ("precise" ones) are given to Embree as a user geometry whose test is
// the watertight one of Woop, Benthin and Wald (JCGT 2(1), 2013) carried out in double: the side
// of the plane is then uncertain by ~1e-16 of the triangle's size, and the margin shrinks to
// that (plus the origin's own rounding, which spawnOrigin adds for every ray).
//
// The hit point of a precise triangle is o + t d in double, which interpolating the float
// vertices (what the caster does for other triangles) would spoil by ulps of the vertices, 1e3
// at 1e10. Embree's hit record has no field for it, so the test writes it, in render space, into
// the hit's geometric normal Ng (which lensfarm never reads otherwise: its normals come from its
// own triangle table), and the caster takes it from there (RayCaster::surfaceHit).
//
// Which triangles are precise: those whose longest edge exceeds kPreciseRatio times the scene's
// feature length, the smaller of the median longest edge of its triangles and the camera's
// distance from the triangle's plane (render space has the camera at its origin). A scene of
// ordinary proportions has none and keeps every bit; one that has some pays the callback only
// for rays that reach their bounds. Triangles of instanced prototypes are always Embree's.
#include <embree3/rtcore.h>

#include <cstdint>
#include <vector>

#include "common/math/vec.h"
#include "common/scene/scene.h"

namespace lensfarm {

// Longest edge over feature length above which a triangle is tested in double: the float margin
// would be above ~2 % of the feature length (2.5 eps_float * 65536). Below it, the floor of
// scenes/glass-metal-sky.json (1000 across, 25,000 of its sphere's triangles) stays Embree's.
inline constexpr double kPreciseRatio = 65536.0;

// Per mesh of scene.meshes, the indices (in the mesh) of its precise triangles, ascending.
std::vector<std::vector<uint32_t>> preciseTrianglesOf(const Scene& scene);

// The spawn margin of a precise triangle: the double test's uncertainty about the plane.
float preciseMargin(const Vec3& v0, const Vec3& v1, const Vec3& v2);

// The precise triangles of one mesh as an Embree user geometry. The hit it reports carries the
// mesh's own triangle index as primID, so the caster finds the triangle as for any other hit.
class PreciseTriangles {
 public:
  // scale: the caster's embreeScale_ (a power of two; rays arrive scaled by it). mask: the
  // geometry's ray mask. The scene and mesh must outlive this.
  PreciseTriangles(const Scene& scene, const TriangleMesh& mesh, const std::vector<uint32_t>& triangles, float scale,
                   unsigned mask);
  // A new geometry (one reference, the caller's) reading this object, which must outlive it.
  RTCGeometry geometry(RTCDevice device) const;

 private:
  struct Triangle {
    DVec3 v0, v1, v2;  // in Embree's space (scaled)
    uint32_t index;    // in the mesh
  };
  const Scene& scene_;
  const TriangleMesh& mesh_;
  std::vector<Triangle> triangles_;
  double scale_;
  unsigned mask_;
  bool cutsOut_ = false;

  static void bounds(const RTCBoundsFunctionArguments* args);
  static void intersect(const RTCIntersectFunctionNArguments* args);
  static void occluded(const RTCOccludedFunctionNArguments* args);
  struct Hit {
    double t, b1, b2;
  };
  // The watertight test of ray (o, d) against triangle k, for t in (0, tFar).
  bool test(const Triangle& tri, const DVec3& o, const DVec3& d, double tFar, Hit& hit) const;
};

}  // namespace lensfarm
