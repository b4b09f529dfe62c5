#pragma once
// A shape's placement (docs/scene-format.md, "transform"): scale, then rotate, then translate,
// M = T·R·S, in double like every world position. Read from the scene file's `transform` object
// and from each keyframe's (scene/keyframes.h), which interpolates the parts, never the matrix.
#include <string>

#include <glm/gtc/quaternion.hpp>

#include "common/math/vec.h"
#include "common/util/field_reader.h"

namespace lensfarm {

// The parts as written. The rotation is kept as axis and angle, which is how the matrix is
// built (glm::rotate), so that a transform read from the file gives the same bits however it
// is reached; `quaternion()` is the same rotation for interpolation.
struct TransformParts {
  DVec3 scale{1.0};           // no component zero
  DVec3 axis{0.0, 0.0, 1.0};  // unit (meaningful when `rotates`)
  double radians = 0.0;       // right-handed about `axis`
  bool rotates = false;       // false: no rotation (R = I)
  DVec3 translate{0.0};

  glm::dmat4 matrix() const;
  glm::dquat quaternion() const;  // the unit quaternion of R (identity when !rotates)
  // The `transform` object that reads back as these parts (scale, rotate, translate).
  json toJson() const;
};

// Reads `transform` object `key` of `parent` (identity when it is absent); every error names the
// field, e.g. "shapes[2].transform.scale: must not be zero".
TransformParts readTransformParts(FieldReader& parent, const std::string& key);

// Scale, then rotate, then translate: the matrix with its uses on points, normals and tangents.
struct Transform {
  glm::dmat4 matrix{1.0};
  DVec3 apply(const DVec3& p) const { return DVec3(matrix * glm::dvec4(p, 1.0)); }
  // Normals go by the inverse transpose, tangents by the matrix itself (both renormalised later).
  glm::dmat3 normalMatrix() const { return glm::transpose(glm::inverse(glm::dmat3(matrix))); }
  Vec3 applyToNormal(const Vec3& n) const { return Vec3(normalMatrix() * DVec3(n)); }
  Vec3 applyToVector(const Vec3& v) const { return Vec3(glm::dmat3(matrix) * DVec3(v)); }
  bool flipsHandedness() const { return glm::determinant(glm::dmat3(matrix)) < 0.0; }
};

inline Transform readTransform(FieldReader& parent, const std::string& key) {
  return Transform{readTransformParts(parent, key).matrix()};
}

}  // namespace lensfarm
