#pragma once
// The extreme-value cases and the scene text each one loads, shared by extreme_values_test (loaded
// in process) and extreme_values_cli_test (through the real `lensfarm` binary).
#include <nlohmann/json.hpp>
#include <string>

#include "tests/test_support.h"

namespace lensfarm::test {

using json = nlohmann::json;

// What a case must give.
enum class Outcome {
  kRefused,  // an InputError whose field is the case's (or `namedAs`)
  kRenders,  // a finite, non-negative image that is not black
  kBlack,    // a finite image that is exactly black (a zero albedo or radiance)
  kFinite,   // a finite, non-negative image, which may be black (a 180 degree view past the quad)
  kLoads,    // loads (too costly to render in a test: 2^40 samples per pixel)
};

struct Case {
  std::string field;  // "camera.f_number", "lights[0].radiance", ...: the JSON path as errors spell it
  std::string value;  // JSON text
  Outcome outcome;
  // kRenders: the image mean must be `ratio` times the mean of the same scene with the field at
  // 1 (colours are linear; same random numbers), within float rounding. 0: not checked.
  double ratio = 0.0;
  std::string namedAs = "";     // kRefused: the field the error names, when another field carries the fault
  json patch = json::object();  // merged into the base scene first (null removes a field)
};

// The minimal scene (a 2 x 2 lit quad 3 units in front of the camera) on a thin lens, at 8 x 8
// pixels and 2 samples per pixel.
inline json baseScene() {
  json j = test::minimalSceneJson();
  j["camera"]["type"] = "thin_lens";
  j["camera"]["f_number"] = 2;
  j["render"]["resolution"] = {8, 8};
  j["render"]["samples_per_pixel"] = 2;
  return j;
}

// "camera.f_number" -> "/camera/f_number"; "lights[0].radiance" -> "/lights/0/radiance".
inline json::json_pointer pointerOf(const std::string& field) {
  std::string p = "/";
  for (char c : field) {
    if (c == '.' || c == '[')
      p += '/';
    else if (c != ']')
      p += c;
  }
  return json::json_pointer(p);
}

// The scene text with `field` set to the JSON text `value` (which may be a literal JSON itself
// cannot hold, such as 1e999).
inline std::string sceneText(const Case& c, const std::string& value) {
  json j = baseScene();
  j.merge_patch(c.patch);
  j[pointerOf(c.field)] = "@VALUE@";
  std::string text = j.dump(2);
  const std::string placeholder = "\"@VALUE@\"";
  text.replace(text.find(placeholder), placeholder.size(), value);
  return text;
}

// The largest float, as JSON text.
inline const std::string kFloatMax = "3.4028234663852886e38";

}  // namespace lensfarm::test
