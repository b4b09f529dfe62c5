#include "common/scene/keyframes.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "common/util/error.h"

namespace lensfarm {

namespace {

std::string shortNumber(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

enum class Kind { kVec3, kPositive, kAngleOfView, kTransform };
struct Property {
  const char* name;
  Kind kind;
};

// What may be keyframed, by the kind of object (the names the object itself uses).
const std::vector<Property> kCameraProperties = {{"position", Kind::kVec3},
                                                 {"look_at", Kind::kVec3},
                                                 {"up", Kind::kVec3},
                                                 {"focus_distance", Kind::kPositive},
                                                 {"f_number", Kind::kPositive},
                                                 {"focal_length", Kind::kPositive},
                                                 {"angle_of_view", Kind::kAngleOfView}};
const std::vector<Property> kShapeProperties = {{"transform", Kind::kTransform}};
const std::vector<Property> kQuadLightProperties = {
    {"corner", Kind::kVec3}, {"edge1", Kind::kVec3}, {"edge2", Kind::kVec3}};
const std::vector<Property> kPointLightProperties = {{"position", Kind::kVec3}};
const std::vector<Property> kSpotLightProperties = {{"position", Kind::kVec3}, {"look_at", Kind::kVec3}};

// One keyframe's value of one property: as written (returned unchanged at its own frame and
// when held), and as read.
struct Key {
  double frame = 0.0;
  size_t index = 0;  // in the keyframes array
  json written;
  double number = 0.0;
  DVec3 vec{0.0};
  TransformParts parts;
};

struct Track {
  Property property;
  std::vector<Key> keys;  // strictly increasing frames
};

// An object with keyframes: where it is, and its tracks (only properties some keyframe gives).
struct Animated {
  json* object = nullptr;
  std::string path;
  std::vector<Track> tracks;
};

Key readKey(FieldReader& k, const Property& p, double frame, size_t index) {
  Key key;
  key.frame = frame;
  key.index = index;
  key.written = k.raw(p.name);
  switch (p.kind) {
    case Kind::kVec3: key.vec = k.dvec3(p.name); break;
    case Kind::kPositive:
      key.number = k.number(p.name);
      if (!(key.number > 0.0)) k.fail(k.field(p.name), "must be > 0, got " + shortNumber(key.number));
      break;
    case Kind::kAngleOfView: key.number = k.number(p.name, 1e-6, 179.999); break;  // as camera.angle_of_view
    case Kind::kTransform: key.parts = readTransformParts(k, p.name); break;
  }
  return key;
}

std::string names(const std::vector<Property>& properties) {
  std::string out;
  for (const Property& p : properties) out += (out.empty() ? "" : ", ") + std::string(p.name);
  return out;
}

Animated readAnimated(json& object, const std::string& path, const std::vector<Property>& properties,
                      const std::string& file) {
  Animated a{&object, path, {}};
  const std::string listField = path + ".keyframes";
  const json& list = object["keyframes"];
  if (!list.is_array() || list.empty())
    throw InputError(file, listField + ": must be a non-empty array of keyframes [{\"frame\": F, ...}, ...]");
  for (const Property& p : properties) a.tracks.push_back(Track{p, {}});
  double previous = 0.0;
  for (size_t i = 0; i < list.size(); ++i) {
    FieldReader k(list[i], listField + "[" + std::to_string(i) + "]", file);
    const double frame = k.number("frame");
    if (i > 0 && !(frame > previous))
      k.fail(k.field("frame"), shortNumber(frame) + " is not after the previous keyframe's frame " +
                                   shortNumber(previous) + " (keyframes are in strictly increasing frame order)");
    previous = frame;
    bool any = false;
    for (Track& track : a.tracks) {
      if (!k.has(track.property.name)) continue;
      any = true;
      track.keys.push_back(readKey(k, track.property, frame, i));
    }
    k.finish();  // a property that cannot be keyframed is an unknown field, listing those that can
    if (!any) k.fail(k.path(), "gives no property besides frame (expected one of: " + names(properties) + ")");
  }
  a.tracks.erase(std::remove_if(a.tracks.begin(), a.tracks.end(), [](const Track& t) { return t.keys.empty(); }),
                 a.tracks.end());
  for (const Track& track : a.tracks) {
    const std::string name = track.property.name;
    if (object.contains(name))
      throw InputError(file, path + "." + name + ": is keyframed too (in " + listField + "): give it in one place");
    if (track.property.kind != Kind::kTransform) continue;
    // A scale whose sign changes between two keyframes would pass through zero (the shape
    // collapses) on the frames between them.
    for (size_t j = 1; j < track.keys.size(); ++j) {
      const DVec3 &s0 = track.keys[j - 1].parts.scale, &s1 = track.keys[j].parts.scale;
      for (int c = 0; c < 3; ++c)
        if ((s0[c] < 0.0) != (s1[c] < 0.0))
          throw InputError(file, listField + "[" + std::to_string(track.keys[j].index) +
                                     "].transform.scale: changes sign from " + listField + "[" +
                                     std::to_string(track.keys[j - 1].index) +
                                     "]'s: the scale would pass through zero between them");
    }
  }
  return a;
}

json valueAt(const Track& track, double frame) {
  const std::vector<Key>& keys = track.keys;
  if (frame <= keys.front().frame) return keys.front().written;  // hold before the first
  if (frame >= keys.back().frame) return keys.back().written;    // and after the last
  // keys[k].frame <= frame < keys[k + 1].frame
  const size_t k =
      size_t(std::upper_bound(keys.begin(), keys.end(), frame, [](double f, const Key& key) { return f < key.frame; }) -
             keys.begin()) -
      1;
  const Key &a = keys[k], &b = keys[k + 1];
  if (a.frame == frame) return a.written;
  const double t = (frame - a.frame) / (b.frame - a.frame);
  switch (track.property.kind) {
    case Kind::kVec3: {
      const DVec3 v = lerpExact(a.vec, b.vec, t);
      return json{v.x, v.y, v.z};
    }
    case Kind::kPositive:
    case Kind::kAngleOfView: return lerpExact(a.number, b.number, t);
    case Kind::kTransform: break;
  }
  return interpolateTransform(a.parts, b.parts, t).toJson();
}

// The objects of the scene that have keyframes, each checked. Objects of the wrong shape are
// left for the loader to report.
std::vector<Animated> findAnimated(json& root, const std::string& file) {
  std::vector<Animated> out;
  if (root.contains("camera") && root["camera"].is_object() && root["camera"].contains("keyframes"))
    out.push_back(readAnimated(root["camera"], "camera", kCameraProperties, file));
  if (root.contains("shapes") && root["shapes"].is_array()) {
    json& shapes = root["shapes"];
    for (size_t i = 0; i < shapes.size(); ++i)
      if (shapes[i].is_object() && shapes[i].contains("keyframes"))
        out.push_back(readAnimated(shapes[i], "shapes[" + std::to_string(i) + "]", kShapeProperties, file));
  }
  if (root.contains("lights") && root["lights"].is_array()) {
    json& lights = root["lights"];
    for (size_t i = 0; i < lights.size(); ++i) {
      json& light = lights[i];
      if (!light.is_object() || !light.contains("keyframes") || !light.contains("type") || !light["type"].is_string())
        continue;
      const std::string path = "lights[" + std::to_string(i) + "]", type = light["type"].get<std::string>();
      const std::vector<Property>* properties = type == "quad"    ? &kQuadLightProperties
                                                : type == "point" ? &kPointLightProperties
                                                : type == "spot"  ? &kSpotLightProperties
                                                                  : nullptr;
      if (!properties)
        throw InputError(file,
                         path + ".keyframes: a " + type +
                             " light cannot be keyframed (the camera, shapes, and quad, point and spot lights can)");
      out.push_back(readAnimated(light, path, *properties, file));
    }
  }
  return out;
}

}  // namespace

double lerpExact(double a, double b, double t) { return a == b ? a : (1.0 - t) * a + t * b; }

DVec3 lerpExact(const DVec3& a, const DVec3& b, double t) {
  return DVec3(lerpExact(a.x, b.x, t), lerpExact(a.y, b.y, t), lerpExact(a.z, b.z, t));
}

TransformParts interpolateTransform(const TransformParts& a, const TransformParts& b, double t) {
  TransformParts out;
  out.scale = lerpExact(a.scale, b.scale, t);
  out.translate = lerpExact(a.translate, b.translate, t);
  if (a.rotates == b.rotates && (!a.rotates || (a.axis == b.axis && a.radians == b.radians))) {
    out.rotates = a.rotates, out.axis = a.axis, out.radians = a.radians;
    return out;
  }
  // glm::slerp takes the shorter arc (it negates one quaternion when their dot product is
  // negative) and mixes linearly when they are nearly equal: normalised again here.
  glm::dquat q = glm::normalize(glm::slerp(a.quaternion(), b.quaternion(), t));
  if (q.w < 0.0) q = -q;  // the same rotation, with its angle in [0, 180] degrees
  const double s = glm::length(DVec3(q.x, q.y, q.z));
  if (!(s > 0.0)) return out;  // no rotation
  out.rotates = true;
  out.axis = DVec3(q.x, q.y, q.z) / s;
  out.radians = 2.0 * std::atan2(s, q.w);  // q = (cos(θ/2), sin(θ/2) axis)
  return out;
}

std::optional<Animation> applyKeyframes(json& root, std::optional<double> frame, const std::string& file) {
  if (frame && !std::isfinite(*frame))
    throw InputError(file, "frame: must be a finite number, got " + shortNumber(*frame));
  if (!root.is_object()) return std::nullopt;
  std::vector<Animated> animated = findAnimated(root, file);
  if (animated.empty()) return std::nullopt;
  Animation out;
  out.range = {std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()};
  for (const Animated& a : animated)
    for (const Track& track : a.tracks) {
      out.range.first = std::min(out.range.first, track.keys.front().frame);
      out.range.last = std::max(out.range.last, track.keys.back().frame);
    }
  out.frame = frame.value_or(out.range.first);
  for (Animated& a : animated) {
    for (const Track& track : a.tracks) (*a.object)[track.property.name] = valueAt(track, out.frame);
    a.object->erase("keyframes");
  }
  return out;
}

}  // namespace lensfarm
