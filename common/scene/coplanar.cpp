#include "scene/coplanar.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "math/ray_offset.h"
#include "math/triangle.h"

namespace lensfarm {

namespace {

constexpr double kEps = std::numeric_limits<float>::epsilon();

struct Box {
  DVec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
  void add(const DVec3& p) { lo = glm::min(lo, p), hi = glm::max(hi, p); }
  bool overlaps(const Box& b, double pad) const {
    for (int c = 0; c < 3; ++c)
      if (lo[c] > b.hi[c] + pad || b.lo[c] > hi[c] + pad) return false;
    return true;
  }
};

double largestAbs(const Vec3& v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); }

// A planar mesh whose every triangle emits from its front only: its plane and largest margin.
struct FlushCandidate {
  size_t mesh;
  DVec3 n;      // unit normal (the emitting side)
  DVec3 point;  // a vertex
  double margin = 0.0, magnitude = 0.0;
  Box box;
};

std::optional<FlushCandidate> planarOneSidedLight(const Scene& scene, size_t index) {
  const TriangleMesh& mesh = scene.meshes[index];
  if (mesh.triangleCount() == 0) return std::nullopt;
  FlushCandidate c{index, {}, {}, 0.0, 0.0, {}};
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const Material& m = scene.materials[mesh.materialIds[t]];
    if (!m.isEmissive() || m.twoSidedEmission) return std::nullopt;
    const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
               &d = mesh.positions[mesh.indices[3 * t + 2]];
    const SpawnPlane plane = spawnPlaneOf(a, b, d);
    const DVec3 n = glm::normalize(triangleCross(a, b, d));
    if (t == 0) c.n = n, c.point = DVec3(a);
    if (glm::dot(n, c.n) < 1.0 - 1e-12) return std::nullopt;  // not one plane
    c.margin = std::max(c.margin, double(plane.margin));
    for (const Vec3* v : {&a, &b, &d}) {
      c.box.add(DVec3(*v));
      c.magnitude = std::max(c.magnitude, largestAbs(*v));
      if (std::abs(glm::dot(c.n, DVec3(*v) - c.point)) > 4.0 * kEps * c.magnitude) return std::nullopt;
    }
  }
  return c;
}

}  // namespace

size_t bringFlushLightsForward(Scene& scene) {
  std::vector<FlushCandidate> lights;
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    if (auto c = planarOneSidedLight(scene, m)) lights.push_back(*c);
  size_t moved = 0;
  for (const FlushCandidate& light : lights) {
    // The partner margin: the largest of the surfaces lying in the light's plane over it.
    double partner = -1.0;
    const double pad = 8.0 * kEps * light.magnitude;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
      if (m == light.mesh) continue;
      const TriangleMesh& mesh = scene.meshes[m];
      for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
                   &d = mesh.positions[mesh.indices[3 * t + 2]];
        Box box;
        for (const Vec3* v : {&a, &b, &d}) box.add(DVec3(*v));
        if (!box.overlaps(light.box, pad)) continue;
        if (!triangleNormal(a, b, d)) continue;
        const SpawnPlane plane = spawnPlaneOf(a, b, d);
        // In the light's plane: every vertex within both triangles' resolution of it.
        const double tolerance = 4.0 * (light.margin + double(plane.margin)) + pad;
        bool coplanar = true;
        for (const Vec3* v : {&a, &b, &d}) coplanar &= std::abs(glm::dot(light.n, DVec3(*v) - light.point)) <= tolerance;
        if (coplanar) partner = std::max(partner, double(plane.margin));
      }
    }
    if (partner < 0.0) continue;
    // Forward by twice the two margins (each bounds Embree's error in one plane test), plus
    // twice the most rounding the moved vertices can undo.
    TriangleMesh& mesh = scene.meshes[light.mesh];
    const double delta = 2.0 * (light.margin + partner) + 2.0 * kEps * light.magnitude;
    for (Vec3& v : mesh.positions) v = Vec3(DVec3(v) + delta * light.n);
    ++moved;
  }
  return moved;
}

}  // namespace lensfarm
