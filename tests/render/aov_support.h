#pragma once
// The wall scene of the AOV tests, shared by aov_test (rendered in process) and aov_cli_test (the
// real `lensfarm` binary).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace lensfarm::test {

using json = nlohmann::json;

// minimalSceneJson: a pinhole at z = -3 looking down +z at a 2 x 2 Lambertian quad (albedo 0.5)
// in the plane z = 0, lit by a quad light the camera does not see. The quad fills the middle of
// the 16 x 16 frame (half-width 1 of the 1.5 the view spans at the wall): pixels 3..12.
inline json wallScene(const std::vector<std::string>& aovs) {
  json scene = test::minimalSceneJson();
  scene["render"]["aovs"] = aovs;
  scene["render"]["samples_per_pixel"] = 8;
  return scene;
}

}  // namespace lensfarm::test
