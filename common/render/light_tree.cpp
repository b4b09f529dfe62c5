#include "common/render/light_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace lensfarm {

namespace {
constexpr int kBuckets = 12;
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// The measure of the directions a cluster emits into (Conty Estevez & Kulla 2018, eq. 1): the
// solid angle of its normals' cone widened by theta_e, weighted by the cosine of emission.
double orientationMeasure(const LightBounds& b) {
  const double pi = std::numbers::pi;
  const double thetaO = std::acos(std::clamp(double(b.normals.cosTheta), -1.0, 1.0));
  const double thetaE = std::acos(std::clamp(double(b.cosThetaE), -1.0, 1.0));
  const double thetaW = std::min(thetaO + thetaE, pi);
  const double sinO = std::sin(thetaO), cosO = std::cos(thetaO);
  return 2.0 * pi * (1.0 - cosO) +
         0.5 * pi * (2.0 * thetaW * sinO - std::cos(thetaO - 2.0 * thetaW) - 2.0 * thetaO * sinO + cosO);
}

// The box's size: its surface area plus its squared diagonal, so that flat and thin clusters (a
// facade's windows, a row of street lamps) still compare by extent.
double boxMeasure(const LightBounds& b) {
  const DVec3 d = DVec3(b.hi) - DVec3(b.lo);
  return 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x) + glm::dot(d, d);
}

double clusterCost(const LightBounds& b) {
  return b.intensity > 0.0f ? double(b.intensity) * orientationMeasure(b) * boxMeasure(b) : 0.0;
}
}  // namespace

LightTree::LightTree(const std::vector<LightBounds>& lights) {
  trail_.assign(lights.size(), 0);
  inTree_.assign(lights.size(), 0);
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < lights.size(); ++i)
    if (lights[i].intensity > 0.0f && std::isfinite(lights[i].intensity)) ids.push_back(i);
  if (ids.empty()) return;
  nodes_.reserve(2 * ids.size() - 1);
  nodes_.resize(1);
  build(ids, 0, ids.size(), lights, 0, 0);
}

void LightTree::build(std::vector<uint32_t>& ids, size_t begin, size_t end, const std::vector<LightBounds>& lights,
                      size_t depth, size_t slot) {
  depth_ = std::max(depth_, depth);
  if (end - begin == 1) {
    nodes_[slot] = Node{LightCluster(lights[ids[begin]]), ids[begin], 1};
    inTree_[ids[begin]] = 1;
    return;
  }
  LightBounds all;
  Vec3 cLo(std::numeric_limits<float>::max()), cHi(-std::numeric_limits<float>::max());
  for (size_t k = begin; k < end; ++k) {
    all = LightBounds::merge(all, lights[ids[k]]);
    cLo = glm::min(cLo, lights[ids[k]].centroid()), cHi = glm::max(cHi, lights[ids[k]].centroid());
  }
  // The split of least cost among the buckets of each axis; in the middle of the list where the
  // centroids coincide, and always near the depth limit (halving from there keeps every trail
  // within 64 bits for up to 2^24 lights).
  size_t mid = begin + (end - begin) / 2;
  const Vec3 extent = cHi - cLo;
  const float largest = std::max(extent.x, std::max(extent.y, extent.z));
  if (depth + 24 < kMaxDepth && largest > 0.0f) {
    double bestCost = std::numeric_limits<double>::infinity();
    int bestAxis = -1, bestBucket = 0;
    auto bucketOf = [&](uint32_t id, int axis) {
      const float f = (lights[id].centroid()[axis] - cLo[axis]) / extent[axis];
      return std::clamp(int(f * float(kBuckets)), 0, kBuckets - 1);
    };
    for (int axis = 0; axis < 3; ++axis) {
      if (!(extent[axis] > 0.0f)) continue;
      LightBounds bucket[kBuckets];
      int count[kBuckets] = {};
      for (size_t k = begin; k < end; ++k) {
        const int b = bucketOf(ids[k], axis);
        bucket[b] = LightBounds::merge(bucket[b], lights[ids[k]]);
        ++count[b];
      }
      // Thin along this axis: a split across it counts for less (pbrt-v4's regularisation).
      const double regularisation = double(largest) / double(extent[axis]);
      for (int split = 0; split + 1 < kBuckets; ++split) {
        LightBounds below, above;
        int countBelow = 0, countAbove = 0;
        for (int b = 0; b <= split; ++b) below = LightBounds::merge(below, bucket[b]), countBelow += count[b];
        for (int b = split + 1; b < kBuckets; ++b) above = LightBounds::merge(above, bucket[b]), countAbove += count[b];
        if (countBelow == 0 || countAbove == 0) continue;
        const double cost = regularisation * (clusterCost(below) + clusterCost(above));
        if (cost < bestCost) bestCost = cost, bestAxis = axis, bestBucket = split;
      }
    }
    if (bestAxis >= 0)
      mid = size_t(std::stable_partition(ids.begin() + long(begin), ids.begin() + long(end),
                                         [&](uint32_t id) { return bucketOf(id, bestAxis) <= bestBucket; }) -
                   ids.begin());
  }
  for (size_t k = mid; k < end; ++k) trail_[ids[k]] |= uint64_t(1) << depth;
  const size_t child = nodes_.size();
  nodes_.resize(child + 2);
  nodes_[slot] = Node{LightCluster(all), uint32_t(child), 0};
  build(ids, begin, mid, lights, depth + 1, child);
  build(ids, mid, end, lights, depth + 1, child + 1);
}

std::optional<float> LightTree::firstChildProbability(uint32_t node, const Vec3& p) const {
  const Node* children = &nodes_[nodes_[node].index];
  const double first = children[0].cluster.importance(p);
  const double second = children[1].cluster.importance(p);
  if (!(first + second > 0.0)) return std::nullopt;
  return float(first / (first + second));
}

std::optional<LightTree::Choice> LightTree::sample(const Vec3& p, float u) const {
  if (nodes_.empty() || !(nodes_[0].cluster.importance(p) > 0.0f)) return std::nullopt;
  uint32_t node = 0;
  float pmf = 1.0f;
  while (!nodes_[node].leaf) {
    const std::optional<float> first = firstChildProbability(node, p);
    if (!first) return std::nullopt;
    if (u < *first) {
      u = std::min(u / *first, kOneMinusEpsilon);
      pmf *= *first;
      node = nodes_[node].index;
    } else {
      const float second = 1.0f - *first;
      u = std::min((u - *first) / second, kOneMinusEpsilon);
      pmf *= second;
      node = nodes_[node].index + 1;
    }
  }
  return Choice{nodes_[node].index, pmf};
}

float LightTree::pmf(const Vec3& p, uint32_t light) const {
  if (light >= inTree_.size() || !inTree_[light] || !(nodes_[0].cluster.importance(p) > 0.0f)) return 0.0f;
  uint32_t node = 0;
  float pmf = 1.0f;
  for (size_t depth = 0; !nodes_[node].leaf; ++depth) {
    const std::optional<float> first = firstChildProbability(node, p);
    if (!first) return 0.0f;
    if ((trail_[light] >> depth) & 1u) {
      pmf *= 1.0f - *first;
      node = nodes_[node].index + 1;
    } else {
      pmf *= *first;
      node = nodes_[node].index;
    }
  }
  return pmf;
}

}  // namespace lensfarm
