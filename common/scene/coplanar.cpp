#include "common/scene/coplanar.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "common/math/ray_offset.h"
#include "common/math/triangle.h"

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

// The one-sided emitting triangles of one mesh that lie in one plane (a lamp), with the vertices
// that only they use: those can move without moving anything else.
struct FlushCandidate {
  size_t mesh;
  std::vector<uint32_t> triangles, vertices;
  DVec3 n;      // unit normal (the emitting side)
  DVec3 point;  // a vertex
  double margin = 0.0, magnitude = 0.0;
  Box box;
};

bool oneSidedEmitter(const Scene& scene, const TriangleMesh& mesh, size_t t) {
  const Material& m = scene.materials[mesh.materialIds[t]];
  return m.isEmissive() && !m.twoSidedEmission;
}

// Groups a mesh's one-sided emitting triangles by plane; keeps the groups whose vertices no other
// triangle uses.
void planarLamps(const Scene& scene, size_t index, std::vector<FlushCandidate>& out) {
  const TriangleMesh& mesh = scene.meshes[index];
  std::vector<FlushCandidate> groups;
  constexpr uint32_t kFree = UINT32_MAX, kShared = UINT32_MAX - 1;
  std::vector<uint32_t> owner(mesh.positions.size(), kFree);  // the group using a vertex
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t* idx = &mesh.indices[3 * t];
    if (!oneSidedEmitter(scene, mesh, t)) {
      for (int k = 0; k < 3; ++k) owner[idx[k]] = kShared;
      continue;
    }
    const Vec3 &a = mesh.positions[idx[0]], &b = mesh.positions[idx[1]], &d = mesh.positions[idx[2]];
    if (!triangleNormal(a, b, d)) continue;
    const DVec3 n = glm::normalize(triangleCross(a, b, d));
    const double magnitude = std::max(largestAbs(DVec3(a)), std::max(largestAbs(DVec3(b)), largestAbs(DVec3(d))));
    size_t g = 0;
    for (; g < groups.size(); ++g) {
      bool same = glm::dot(n, groups[g].n) >= 1.0 - 1e-12;
      for (const Vec3* v : {&a, &b, &d})
        same &= std::abs(glm::dot(groups[g].n, DVec3(*v) - groups[g].point)) <=
                4.0 * kEps * std::max(magnitude, groups[g].magnitude);
      if (same) break;
    }
    if (g == groups.size()) {
      FlushCandidate c;
      c.mesh = index, c.n = n, c.point = DVec3(a);
      groups.push_back(c);
    }
    FlushCandidate& c = groups[g];
    c.triangles.push_back(uint32_t(t));
    c.margin = std::max(c.margin, double(spawnPlaneOf(a, b, d).margin));
    c.magnitude = std::max(c.magnitude, magnitude);
    for (int k = 0; k < 3; ++k) {
      c.box.add(DVec3(mesh.positions[idx[k]]));
      owner[idx[k]] = owner[idx[k]] == kFree || owner[idx[k]] == g ? uint32_t(g) : kShared;
    }
  }
  for (size_t g = 0; g < groups.size(); ++g) {
    bool exclusive = true;
    for (uint32_t t : groups[g].triangles)
      for (int k = 0; k < 3; ++k) exclusive &= owner[mesh.indices[3 * t + k]] == g;
    if (!exclusive) continue;
    for (uint32_t v = 0; v < owner.size(); ++v)
      if (owner[v] == g) groups[g].vertices.push_back(v);
    out.push_back(std::move(groups[g]));
  }
}

}  // namespace

size_t bringFlushLightsForward(Scene& scene) {
  std::vector<FlushCandidate> lamps;
  for (size_t m = 0; m < scene.meshes.size(); ++m) planarLamps(scene, m, lamps);
  size_t moved = 0;
  for (const FlushCandidate& lamp : lamps) {
    // The partner margin: the largest of the surfaces lying in the lamp's plane over it.
    double partner = -1.0;
    const double pad = 8.0 * kEps * lamp.magnitude;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
      const TriangleMesh& mesh = scene.meshes[m];
      for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        if (m == lamp.mesh && oneSidedEmitter(scene, mesh, t)) continue;  // the lamp itself, or another
        const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
                   &d = mesh.positions[mesh.indices[3 * t + 2]];
        Box box;
        for (const Vec3* v : {&a, &b, &d}) box.add(DVec3(*v));
        if (!box.overlaps(lamp.box, pad)) continue;
        if (!triangleNormal(a, b, d)) continue;
        const SpawnPlane plane = spawnPlaneOf(a, b, d);
        // In the lamp's plane: every vertex within both triangles' resolution of it.
        const double tolerance = 4.0 * (lamp.margin + double(plane.margin)) + pad;
        bool coplanar = true;
        for (const Vec3* v : {&a, &b, &d}) coplanar &= std::abs(glm::dot(lamp.n, DVec3(*v) - lamp.point)) <= tolerance;
        if (coplanar) partner = std::max(partner, double(plane.margin));
      }
    }
    if (partner < 0.0) continue;
    // Forward by twice the two margins (each bounds Embree's error in one plane test), plus
    // twice the most rounding the moved vertices can undo.
    TriangleMesh& mesh = scene.meshes[lamp.mesh];
    const double delta = 2.0 * (lamp.margin + partner) + 2.0 * kEps * lamp.magnitude;
    for (uint32_t v : lamp.vertices) mesh.positions[v] = Vec3(DVec3(mesh.positions[v]) + delta * lamp.n);
    ++moved;
  }
  return moved;
}

}  // namespace lensfarm
