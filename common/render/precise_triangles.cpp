#include "common/render/precise_triangles.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "common/math/triangle.h"
#include "common/render/cutout.h"

namespace lensfarm {

namespace {
double longestEdge(const DVec3& a, const DVec3& b, const DVec3& c) {
  return std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
}
}  // namespace

std::vector<std::vector<uint32_t>> preciseTrianglesOf(const Scene& scene) {
  std::vector<std::vector<uint32_t>> precise(scene.meshes.size());
  // The median longest edge, over at most ~65536 triangles taken evenly (deterministic).
  size_t count = 0;
  for (const TriangleMesh& mesh : scene.meshes) count += mesh.triangleCount();
  if (count == 0) return precise;
  const size_t stride = std::max<size_t>(1, count / 65536);
  std::vector<double> edges;
  size_t k = 0;
  for (const TriangleMesh& mesh : scene.meshes)
    for (size_t tri = 0; tri < mesh.triangleCount(); ++tri, ++k) {
      const DVec3 a(mesh.positions[mesh.indices[3 * tri]]), b(mesh.positions[mesh.indices[3 * tri + 1]]),
          c(mesh.positions[mesh.indices[3 * tri + 2]]);
      const double edge = longestEdge(a, b, c);
      if (k % stride == 0) edges.push_back(edge);
    }
  auto middle = edges.begin() + ptrdiff_t(edges.size() / 2);
  std::nth_element(edges.begin(), middle, edges.end());
  const double median = *middle > 0.0 ? *middle : std::numeric_limits<double>::infinity();
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const TriangleMesh& mesh = scene.meshes[m];
    for (size_t tri = 0; tri < mesh.triangleCount(); ++tri) {
      const Vec3 &a = mesh.positions[mesh.indices[3 * tri]], &b = mesh.positions[mesh.indices[3 * tri + 1]],
                 &c = mesh.positions[mesh.indices[3 * tri + 2]];
      const double edge = longestEdge(DVec3(a), DVec3(b), DVec3(c));
      const DVec3 cross = triangleCross(a, b, c);
      const double length = glm::length(cross);
      if (!(length > 0.0) || !std::isfinite(length)) continue;  // zero area: never hit
      // The camera's distance from the plane (it stands at render space's origin); zero (the
      // camera in the plane) says nothing of the scene's scale.
      const double camera = std::abs(glm::dot(cross / length, DVec3(a)));
      const double feature = camera > 0.0 ? std::min(median, camera) : median;
      if (edge > kPreciseRatio * feature) precise[m].push_back(uint32_t(tri));
    }
  }
  return precise;
}

float preciseMargin(const Vec3& v0, const Vec3& v1, const Vec3& v2) {
  // The double test's edge and distance terms carry a few roundings of lengths up to the
  // longest edge (the origin lies on the triangle when spawning): 16 ulps of double, kept well
  // above any rounding of the test and far below anything a scene can hold (2e-5 at 1e10).
  return float(16.0 * std::numeric_limits<double>::epsilon() * longestEdge(DVec3(v0), DVec3(v1), DVec3(v2)));
}

PreciseTriangles::PreciseTriangles(const Scene& scene, const TriangleMesh& mesh, const std::vector<uint32_t>& triangles,
                                   float scale, unsigned mask)
    : scene_(scene), mesh_(mesh), scale_(scale), mask_(mask), cutsOut_(meshCutsOut(scene, mesh)) {
  triangles_.reserve(triangles.size());
  for (const uint32_t tri : triangles) {
    const auto vertex = [&](int c) { return DVec3(mesh.positions[mesh.indices[3 * tri + c]]) * scale_; };
    triangles_.push_back(Triangle{vertex(0), vertex(1), vertex(2), tri});
  }
}

RTCGeometry PreciseTriangles::geometry(RTCDevice device) const {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(geom, unsigned(triangles_.size()));
  rtcSetGeometryUserData(geom, const_cast<PreciseTriangles*>(this));
  rtcSetGeometryBoundsFunction(geom, bounds, nullptr);
  rtcSetGeometryIntersectFunction(geom, intersect);
  rtcSetGeometryOccludedFunction(geom, occluded);
  rtcSetGeometryMask(geom, mask_);
  return geom;
}

void PreciseTriangles::bounds(const RTCBoundsFunctionArguments* args) {
  const auto* self = static_cast<const PreciseTriangles*>(args->geometryUserPtr);
  const Triangle& t = self->triangles_[args->primID];
  // The vertices are floats scaled by a power of two: exact in float, so the box is exact.
  const DVec3 lo = glm::min(t.v0, glm::min(t.v1, t.v2)), hi = glm::max(t.v0, glm::max(t.v1, t.v2));
  RTCBounds* b = args->bounds_o;
  b->lower_x = float(lo.x), b->lower_y = float(lo.y), b->lower_z = float(lo.z);
  b->upper_x = float(hi.x), b->upper_y = float(hi.y), b->upper_z = float(hi.z);
}

// Woop, Benthin and Wald's watertight test (JCGT 2(1), 2013), in double: the ray is sheared so
// that it runs along +z through the origin; the 2D edge functions of the sheared vertices then
// decide the hit with one consistent rounding per edge, so a ray cannot slip between two
// triangles sharing an edge.
bool PreciseTriangles::test(const Triangle& tri, const DVec3& o, const DVec3& d, double tFar, Hit& hit) const {
  const DVec3 ad = glm::abs(d);
  const int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
  if (d[kz] < 0.0) std::swap(kx, ky);  // keeps the winding, so the sign tests hold
  const double sx = d[kx] / d[kz], sy = d[ky] / d[kz], sz = 1.0 / d[kz];
  const DVec3 a = tri.v0 - o, b = tri.v1 - o, c = tri.v2 - o;
  const double ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
  const double bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
  const double cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
  const double u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
  if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
  const double det = u + v + w;
  if (det == 0.0) return false;
  const double t = (u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz])) / det;
  if (!(t > 0.0 && t < tFar)) return false;
  hit = Hit{t, v / det, w / det};  // weights of v1 and v2: Embree's u and v
  return true;
}

void PreciseTriangles::intersect(const RTCIntersectFunctionNArguments* args) {
  const auto* self = static_cast<const PreciseTriangles*>(args->geometryUserPtr);
  const Triangle& tri = self->triangles_[args->primID];
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* out = RTCRayHitN_HitN(args->rayhit, args->N);
  const unsigned N = args->N;
  for (unsigned i = 0; i < N; ++i) {
    if (args->valid[i] != -1 || (RTCRayN_mask(ray, N, i) & self->mask_) == 0) continue;
    const DVec3 o(RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i));
    const DVec3 d(RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i));
    Hit hit;
    if (!self->test(tri, o, d, double(RTCRayN_tfar(ray, N, i)), hit)) continue;
    const float b1 = float(hit.b1), b2 = float(hit.b2);
    if (self->cutsOut_ && cutsAway(self->scene_, self->mesh_, tri.index, b1, b2)) continue;
    const float t = float(hit.t);
    if (!(t < RTCRayN_tfar(ray, N, i))) continue;  // (rounding t to float may reach tfar)
    RTCRayN_tfar(ray, N, i) = t;
    // The point in render space (the scale is a power of two), in Ng (header).
    const DVec3 p = (o + hit.t * d) / self->scale_;
    RTCHitN_Ng_x(out, N, i) = float(p.x);
    RTCHitN_Ng_y(out, N, i) = float(p.y);
    RTCHitN_Ng_z(out, N, i) = float(p.z);
    RTCHitN_u(out, N, i) = b1;
    RTCHitN_v(out, N, i) = b2;
    RTCHitN_primID(out, N, i) = tri.index;
    RTCHitN_geomID(out, N, i) = args->geomID;
    RTCHitN_instID(out, N, i, 0) = args->context->instID[0];
  }
}

void PreciseTriangles::occluded(const RTCOccludedFunctionNArguments* args) {
  const auto* self = static_cast<const PreciseTriangles*>(args->geometryUserPtr);
  const Triangle& tri = self->triangles_[args->primID];
  const unsigned N = args->N;
  for (unsigned i = 0; i < N; ++i) {
    if (args->valid[i] != -1 || (RTCRayN_mask(args->ray, N, i) & self->mask_) == 0) continue;
    const DVec3 o(RTCRayN_org_x(args->ray, N, i), RTCRayN_org_y(args->ray, N, i), RTCRayN_org_z(args->ray, N, i));
    const DVec3 d(RTCRayN_dir_x(args->ray, N, i), RTCRayN_dir_y(args->ray, N, i), RTCRayN_dir_z(args->ray, N, i));
    Hit hit;
    if (!self->test(tri, o, d, double(RTCRayN_tfar(args->ray, N, i)), hit)) continue;
    if (self->cutsOut_ && cutsAway(self->scene_, self->mesh_, tri.index, float(hit.b1), float(hit.b2))) continue;
    RTCRayN_tfar(args->ray, N, i) = -std::numeric_limits<float>::infinity();
  }
}

}  // namespace lensfarm
