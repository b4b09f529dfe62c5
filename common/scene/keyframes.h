#pragma once
// Keyframe animation in the scene file (docs/scene-format.md, "Animation"). The camera, any
// shape, and quad, point and spot lights may carry
//   "keyframes": [{"frame": F, <property>: <value>, ...}, ...]
// Each property is a track of its own, interpolated between the keyframes that give it:
// numbers and vec3s linearly, a shape's `transform` part by part (scale and translate linearly,
// the rotation by spherical linear interpolation of unit quaternions on the shorter arc,
// Shoemake 1985, "Animating rotation with quaternion curves", SIGGRAPH '85). Before a track's
// first keyframe and after its last, it holds that keyframe's value; at a keyframe's frame it is
// exactly the value written there.
//
// Frames are numbers (integers in practice; fractional ones are allowed). The scene is evaluated
// on its JSON, before anything is read: each keyframed property is written into its object as if
// it had been given there, so every check the loader makes on a static scene applies to the
// evaluated one, and a scene without keyframes is parsed exactly as before.
#include <optional>
#include <string>

#include "common/scene/scene.h"
#include "common/scene/transform.h"
#include "common/util/field_reader.h"

namespace lensfarm {

struct Animation {
  KeyframeRange range;  // the first keyframe's frame and the last one's, over every track
  double frame = 0.0;   // the frame the scene was evaluated at
};

// Evaluates every `keyframes` array of a scene's JSON at `frame` (none: the scene's first
// keyframe's frame), in place: each keyframed property is set on its object and the arrays are
// removed. Returns nothing, and leaves `root` untouched, if the scene has no keyframes. Every
// keyframe is checked whatever the frame; an error names the file and the field, e.g.
// "scene.json: camera.keyframes[2].frame: 3 is not after the previous keyframe's frame 5 ...".
std::optional<Animation> applyKeyframes(json& root, std::optional<double> frame, const std::string& file);

// (1 - t) a + t b, and exactly a where a == b (a property that does not change between two
// keyframes stays bit for bit what was written).
double lerpExact(double a, double b, double t);
DVec3 lerpExact(const DVec3& a, const DVec3& b, double t);

// Transform parts at fraction t in [0, 1] from a to b: scale and translate by lerpExact, the
// rotation by slerp on the shorter arc (at most 180 degrees between two keyframes). A rotation
// that does not change is kept as written.
TransformParts interpolateTransform(const TransformParts& a, const TransformParts& b, double t);

}  // namespace lensfarm
