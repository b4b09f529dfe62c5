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

// Every triangle of the scene's meshes in the cells of a uniform grid its box overlaps (those
// overlapping very many cells in a list of their own), so that the triangles near a lamp are found
// without visiting all of them: a scene of many lamps is not quadratic in its triangles.
class TriangleGrid {
 public:
  explicit TriangleGrid(const Scene& scene) {
    std::vector<std::pair<uint64_t, Box>> boxes;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
      const TriangleMesh& mesh = scene.meshes[m];
      for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        Box box;
        for (int k = 0; k < 3; ++k) box.add(DVec3(mesh.positions[mesh.indices[3 * t + k]]));
        bounds_.add(box.lo), bounds_.add(box.hi);
        boxes.push_back({uint64_t(m) << 32 | t, box});
      }
    }
    res_ = std::clamp(int(std::cbrt(double(boxes.size()) / 2.0)), 1, 64);
    const DVec3 extent = bounds_.hi - bounds_.lo;
    for (int c = 0; c < 3; ++c) scale_[c] = extent[c] > 0.0 ? double(res_) / extent[c] : 0.0;
    // Counts, then entries (compressed rows).
    start_.assign(size_t(res_) * res_ * res_ + 1, 0);
    const auto each = [&](const Box& box, auto&& visit) {
      int lo[3], hi[3];
      range(box, 0.0, lo, hi);
      if (int64_t(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) > kLargeCells) return false;
      for (int z = lo[2]; z <= hi[2]; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x) visit(cellIndex(x, y, z));
      return true;
    };
    for (const auto& [id, box] : boxes)
      if (!each(box, [&](size_t c) { ++start_[c + 1]; })) large_.push_back(id);
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    entries_.resize(start_.back());
    std::vector<size_t> fill(start_.begin(), start_.end() - 1);
    for (const auto& [id, box] : boxes) each(box, [&, id = id](size_t c) { entries_[fill[c]++] = id; });
  }

  // Calls visit(mesh, triangle) for every triangle whose box may overlap `box` padded by pad
  // (some more than once), also after lamps have moved forward (by far less than the slack: a few
  // margins, each a few float steps of the scene's magnitude).
  template <typename Visit>
  void near(const Box& box, double pad, Visit&& visit) const {
    for (uint64_t id : large_) visit(size_t(id >> 32), size_t(id & 0xffffffffu));
    int lo[3], hi[3];
    const double slack = 1024.0 * kEps * std::max(largestAbs(bounds_.lo), largestAbs(bounds_.hi));
    range(box, pad + slack, lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const size_t c = cellIndex(x, y, z);
          for (size_t e = start_[c]; e < start_[c + 1]; ++e)
            visit(size_t(entries_[e] >> 32), size_t(entries_[e] & 0xffffffffu));
        }
  }

 private:
  static constexpr int64_t kLargeCells = 64;
  size_t cellIndex(int x, int y, int z) const {
    return (size_t(z) * size_t(res_) + size_t(y)) * size_t(res_) + size_t(x);
  }
  void range(const Box& box, double pad, int (&lo)[3], int (&hi)[3]) const {
    for (int c = 0; c < 3; ++c) {
      const auto cell = [&](double v) {
        return std::clamp(int(std::floor((v - bounds_.lo[c]) * scale_[c])), 0, res_ - 1);
      };
      lo[c] = cell(box.lo[c] - pad), hi[c] = cell(box.hi[c] + pad);
    }
  }

  Box bounds_;
  int res_ = 1;
  double scale_[3] = {};
  std::vector<size_t> start_;
  std::vector<uint64_t> entries_, large_;
};

}  // namespace

size_t bringFlushLightsForward(Scene& scene) {
  std::vector<FlushCandidate> lamps;
  for (size_t m = 0; m < scene.meshes.size(); ++m) planarLamps(scene, m, lamps);
  if (lamps.empty()) return 0;
  const TriangleGrid grid(scene);
  size_t moved = 0;
  for (const FlushCandidate& lamp : lamps) {
    // The partner margin: the largest of the surfaces lying in the lamp's plane over it.
    double partner = -1.0;
    const double pad = 8.0 * kEps * lamp.magnitude;
    grid.near(lamp.box, pad, [&](size_t m, size_t t) {
      const TriangleMesh& mesh = scene.meshes[m];
      {
        if (m == lamp.mesh && oneSidedEmitter(scene, mesh, t)) return;  // the lamp itself, or another
        const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
                   &d = mesh.positions[mesh.indices[3 * t + 2]];
        Box box;
        for (const Vec3* v : {&a, &b, &d}) box.add(DVec3(*v));
        if (!box.overlaps(lamp.box, pad)) return;
        if (!triangleNormal(a, b, d)) return;
        const SpawnPlane plane = spawnPlaneOf(a, b, d);
        // In the lamp's plane: every vertex within both triangles' resolution of it.
        const double tolerance = 4.0 * (lamp.margin + double(plane.margin)) + pad;
        bool coplanar = true;
        for (const Vec3* v : {&a, &b, &d}) coplanar &= std::abs(glm::dot(lamp.n, DVec3(*v) - lamp.point)) <= tolerance;
        if (coplanar) partner = std::max(partner, double(plane.margin));
      }
    });
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
