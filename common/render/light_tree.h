#pragma once
// A light tree (Conty Estevez & Kulla 2018, "Importance Sampling of Many Lights with Adaptive
// Tree Splitting"; as in Cycles and pbrt-v4's BVHLightSampler): a binary tree over the lights in
// the scene, each node holding the bounds of the lights below it (light/light_bounds.h). A light
// sample descends from the root, at each node taking a child with probability proportional to its
// importance at the shading point, so a light is chosen in proportion to an estimate of what it
// sends there rather than to its power alone: of a city's ten thousand windows, those near the
// street corner and facing it.
//
// The probability of the light chosen is the product of the choices on its way down; pmf() walks
// the same way to the light (by the bits of its trail) and computes the same products in the same
// order, so it gives the bits sample() gave, which multiple importance sampling needs of a light a
// scattered ray hits. Everything is a function of the lights' bounds and the point: the same
// choice on every machine, thread and worker.
//
// Built with the surface area orientation heuristic (Conty Estevez & Kulla 2018, §4.4): a node's
// lights are split where intensity x box size x the orientation cone's measure, summed over the
// two halves, is least, among 12 buckets of the centroids along each axis.
#include <cstdint>
#include <optional>
#include <vector>

#include "common/light/light_bounds.h"
#include "common/math/vec.h"

namespace lensfarm {

class LightTree {
 public:
  // lights[i]: the bounds of light i; a light of zero intensity is never chosen.
  explicit LightTree(const std::vector<LightBounds>& lights);
  LightTree() = default;

  bool empty() const { return nodes_.empty(); }
  size_t depth() const { return depth_; }
  size_t nodeCount() const { return nodes_.size(); }

  struct Choice {
    uint32_t light;
    float pmf;
  };
  // The light for sample value u in [0, 1) as seen from p; nothing where no light can reach p.
  std::optional<Choice> sample(const Vec3& p, float u) const;
  // The probability that sample() chooses `light` from p (0 where it cannot).
  float pmf(const Vec3& p, uint32_t light) const;

 private:
  struct Node {
    LightCluster cluster;
    // A leaf: the light; an inner node: its first child (the second is the node after it, so a
    // level's two importances read neighbouring nodes).
    uint32_t index;
    uint32_t leaf;
  };
  // Fills node `slot` with the lights ids[begin, end).
  void build(std::vector<uint32_t>& ids, size_t begin, size_t end, const std::vector<LightBounds>& lights, size_t depth,
             size_t slot);
  // The probability of taking the first child of inner node `node` at p, or nothing where
  // neither child can reach p.
  std::optional<float> firstChildProbability(uint32_t node, const Vec3& p) const;

  std::vector<Node> nodes_;  // the root at 0, each node's children together
  // Per light: bit d set where its way down takes the second child at depth d (depth is at most
  // kMaxDepth < 64); inTree_ 0 for a light left out (zero or non-finite intensity).
  std::vector<uint64_t> trail_;
  std::vector<uint8_t> inTree_;
  size_t depth_ = 0;
  static constexpr size_t kMaxDepth = 63;
};

}  // namespace lensfarm
