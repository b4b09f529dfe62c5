#include "common/scene/transform.h"

#include <glm/gtc/matrix_transform.hpp>

namespace lensfarm {

glm::dmat4 TransformParts::matrix() const {
  const DVec3& k = scale;
  const glm::dmat4 s(glm::dvec4(k.x, 0, 0, 0), glm::dvec4(0, k.y, 0, 0), glm::dvec4(0, 0, k.z, 0),
                     glm::dvec4(0, 0, 0, 1));
  const glm::dmat4 r = rotates ? glm::rotate(glm::dmat4(1.0), radians, axis) : glm::dmat4(1.0);
  glm::dmat4 t(1.0);
  t[3] = glm::dvec4(translate, 1.0);
  return t * r * s;
}

glm::dquat TransformParts::quaternion() const {
  return rotates ? glm::angleAxis(radians, axis) : glm::dquat(1.0, 0.0, 0.0, 0.0);
}

json TransformParts::toJson() const {
  json out = {{"scale", {scale.x, scale.y, scale.z}}, {"translate", {translate.x, translate.y, translate.z}}};
  if (rotates) out["rotate"] = {{"axis", {axis.x, axis.y, axis.z}}, {"degrees", glm::degrees(radians)}};
  return out;
}

TransformParts readTransformParts(FieldReader& parent, const std::string& key) {
  TransformParts t;
  if (!parent.has(key)) return t;
  FieldReader r(parent.raw(key), parent.field(key), parent.file());
  if (r.has("scale")) {
    const json& s = r.raw("scale");
    t.scale = s.is_number() ? DVec3(r.number("scale")) : r.dvec3("scale");
    if (t.scale.x == 0.0 || t.scale.y == 0.0 || t.scale.z == 0.0) r.fail(r.field("scale"), "must not be zero");
  }
  if (r.has("rotate")) {
    FieldReader rot(r.raw("rotate"), r.field("rotate"), r.file());
    const DVec3 axis = rot.dvec3("axis");
    // Divided by its largest component first, so that no length overflows (an axis of 1e300).
    const double largest = largestAbs(axis);
    if (!(largest > 0.0)) rot.fail(rot.field("axis"), "must not be zero");
    const double degrees = rot.number("degrees", -360.0, 360.0);
    rot.finish();
    t.axis = glm::normalize(axis / largest);
    t.radians = glm::radians(degrees);
    t.rotates = true;
  }
  if (r.has("translate")) t.translate = r.dvec3("translate");
  r.finish();
  return t;
}

}  // namespace lensfarm
