#pragma once
// Scenes built in code at any scale and position (the hard cases of docs/numerics.md: the same
// image at 1e6 from the origin and at 1e-4 / 1e6 scale): a point of the unit scene, scaled and
// moved, and a vector (a size, an edge), only scaled; both as the scene format's JSON arrays.
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

namespace lensfarm::test {

struct PlacedPoint {
  double scale = 1.0;
  glm::dvec3 offset{0.0};
  nlohmann::json operator()(double x, double y, double z) const {
    return nlohmann::json::array({offset.x + scale * x, offset.y + scale * y, offset.z + scale * z});
  }
};

struct ScaledVector {
  double scale = 1.0;
  nlohmann::json operator()(double x, double y, double z) const {
    return nlohmann::json::array({scale * x, scale * y, scale * z});
  }
};

}  // namespace lensfarm::test
