// The angle of view a scene asks for is the angle the image has: measured on the rays through
// the image's edges, against the pinhole formula tan(a/2) = (L/2) / f, whatever the distance to
// look_at, the image's aspect ratio, the axis the angle is given along (fov_axis) or a resolution
// given later on the command line. A thin lens focused near sees less, and the scene's notes say
// how much (focus breathing).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "common/camera/thin_lens_camera.h"
#include "common/scene/render_overrides.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

constexpr double kDegree = std::numbers::pi / 180.0;

// The full angle between the rays through the outer edges of the image along one axis, each
// measured in the plane of that axis and the optical axis (so a ray half a cell off the middle
// row or column measures the same), on the camera's own rays.
double measuredAngle(const ThinLensCamera& camera, bool horizontal) {
  const int w = camera.width(), h = camera.height();
  const Vec3 side = horizontal ? camera.right() : camera.up();
  const auto angleTo = [&](const CameraRay& ray) {
    return std::atan2(std::abs(double(glm::dot(ray.direction, side))),
                      double(glm::dot(ray.direction, camera.forward())));
  };
  // Cell edges: cell 0 at offset 0 and the last cell at offset just below 1.
  const float uMax = 0x1.fffffep-1f;
  if (horizontal)
    return (angleTo(camera.generatePinholeRay(0, h / 2, Vec2(0.0f, 0.5f))) +
            angleTo(camera.generatePinholeRay(w - 1, h / 2, Vec2(uMax, 0.5f)))) /
           kDegree;
  return (angleTo(camera.generatePinholeRay(w / 2, 0, Vec2(0.5f, 0.0f))) +
          angleTo(camera.generatePinholeRay(w / 2, h - 1, Vec2(0.5f, uMax)))) /
         kDegree;
}

double measuredDiagonal(const ThinLensCamera& camera) {
  const float uMax = 0x1.fffffep-1f;
  const auto angleTo = [&](const CameraRay& ray) {
    return std::acos(std::clamp(double(glm::dot(ray.direction, camera.forward())), -1.0, 1.0));
  };
  return (angleTo(camera.generatePinholeRay(0, 0, Vec2(0.0f))) +
          angleTo(camera.generatePinholeRay(camera.width() - 1, camera.height() - 1, Vec2(uMax)))) /
         kDegree;
}

Scene sceneWith(const test::TempDir& dir, json camera, int width, int height) {
  json j = test::minimalSceneJson();
  j["camera"] = std::move(camera);
  j["render"]["resolution"] = {width, height};
  return test::loadSceneJson(dir, j);
}

bool hasNote(const Scene& s, const std::string& part) {
  for (const std::string& n : s.notes)
    if (n.find(part) != std::string::npos) return true;
  return false;
}

TEST(FieldOfView, APinholeSeesItsAngleWhateverTheDistanceToLookAt) {
  // Mitsuba's Cornell box camera looks at a target one unit ahead with a 39.3077-degree view;
  // the same camera aimed at a point 1e4 units ahead must see the same angle.
  const test::TempDir dir;
  for (const double distance : {1e-3, 1.0, 3.0, 1e4})
    for (const json& lens : {json{{"angle_of_view", 39.3077}}, json{{"focal_length", 0.05}, {"sensor_width", 0.036}}}) {
      // (Lengths longer than the distance to look_at are refused as a unit slip: not this case.)
      if (lens.contains("focal_length") && distance < 0.05) continue;
      json camera = {
          {"type", "pinhole"}, {"position", {0, 0, -3}}, {"look_at", {0, 0, -3 + distance}}, {"up", {0, 1, 0}}};
      camera.update(lens);
      const Scene s = sceneWith(dir, camera, 256, 256);
      const double expected =
          lens.contains("angle_of_view") ? 39.3077 : 2.0 * std::atan(0.036 / (2.0 * 0.05)) / kDegree;
      EXPECT_NEAR(measuredAngle(s.camera(), true), expected, 1e-4)
          << "look_at " << distance << " ahead, " << lens.dump();
      EXPECT_NEAR(measuredAngle(s.camera(), false), expected, 1e-4) << "look_at " << distance << " ahead";
    }
}

TEST(FieldOfView, EachAxisHoldsItsAngleAtLandscapeAndPortraitSizes) {
  const test::TempDir dir;
  const double a = 40.0, t = std::tan(a / 2.0 * kDegree);
  for (const auto& [w, h] : {std::pair{160, 90}, std::pair{90, 160}, std::pair{64, 64}}) {
    const double aspect = double(w) / h;
    // The other axis's angle from the pinhole formula: its half-extent is tan(a/2) scaled by the
    // ratio of the two sides.
    const auto other = [&](double ratio) { return 2.0 * std::atan(t * ratio) / kDegree; };
    json camera = {{"type", "pinhole"}, {"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}, {"angle_of_view", a}};
    const std::string size = std::to_string(w) + "x" + std::to_string(h);

    camera["fov_axis"] = "horizontal";
    ThinLensCamera c = sceneWith(dir, camera, w, h).camera();
    EXPECT_NEAR(measuredAngle(c, true), a, 1e-4) << size;
    EXPECT_NEAR(measuredAngle(c, false), other(1.0 / aspect), 1e-4) << size;

    camera["fov_axis"] = "vertical";
    c = sceneWith(dir, camera, w, h).camera();
    EXPECT_NEAR(measuredAngle(c, false), a, 1e-4) << size;
    EXPECT_NEAR(measuredAngle(c, true), other(aspect), 1e-4) << size;

    camera["fov_axis"] = "smaller";
    c = sceneWith(dir, camera, w, h).camera();
    EXPECT_NEAR(measuredAngle(c, w <= h), a, 1e-4) << size;
    camera["fov_axis"] = "larger";
    c = sceneWith(dir, camera, w, h).camera();
    EXPECT_NEAR(measuredAngle(c, w >= h), a, 1e-4) << size;

    camera["fov_axis"] = "diagonal";
    c = sceneWith(dir, camera, w, h).camera();
    EXPECT_NEAR(measuredDiagonal(c), a, 1e-4) << size;
  }
}

TEST(FieldOfView, AResolutionGivenLaterKeepsTheVerticalAngle) {
  // The farm and `render --resolution` apply the resolution after the scene is read: the camera
  // is built at the final size, so a vertical angle stays vertical.
  const test::TempDir dir;
  Scene s = sceneWith(dir,
                      {{"type", "pinhole"},
                       {"position", {0, 0, -3}},
                       {"look_at", {0, 0, 0}},
                       {"angle_of_view", 30},
                       {"fov_axis", "vertical"}},
                      64, 64);
  RenderOverrides o;
  parseResolution("320x90", o);
  applyOverrides(o, s.render, "test");
  EXPECT_NEAR(measuredAngle(s.camera(), false), 30.0, 1e-4);
  EXPECT_NEAR(measuredAngle(s.camera(), true), 2.0 * std::atan(std::tan(15.0 * kDegree) * 320.0 / 90.0) / kDegree,
              1e-4);
}

TEST(FieldOfView, AThinLensFocusedNearSaysHowMuchItBreathes) {
  const test::TempDir dir;
  // f = 0.095 focused at 0.5: S2 = f S1 / (S1 - f) = 0.11728, so the view narrows from
  // 2 atan(0.05 / 0.095) = 55.52 degrees to 2 atan(0.05 / 0.11728) = 46.18.
  const json lens = {{"type", "thin_lens"}, {"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}, {"focal_length", 0.095},
                     {"sensor_width", 0.1}, {"f_number", 8},          {"focus_distance", 0.5}};
  const Scene near = sceneWith(dir, lens, 64, 64);
  EXPECT_NEAR(measuredAngle(near.camera(), true), 2.0 * std::atan(0.05 / (0.095 * 0.5 / (0.5 - 0.095))) / kDegree,
              1e-3);
  EXPECT_TRUE(hasNote(near, "the thin lens sees 46.178")) << (near.notes.empty() ? "" : near.notes.back());
  // Focused far away the difference is below half a percent: no note.
  json far = lens;
  far["focus_distance"] = 100.0;
  EXPECT_FALSE(hasNote(sceneWith(dir, far, 64, 64), "the thin lens sees"));
  // A pinhole has no focus: a focus_distance is ignored, and said to be.
  json pinhole = {{"type", "pinhole"},
                  {"position", {0, 0, -3}},
                  {"look_at", {0, 0, 0}},
                  {"angle_of_view", 40},
                  {"focus_distance", 0.5}};
  const Scene p = sceneWith(dir, pinhole, 64, 64);
  EXPECT_NEAR(measuredAngle(p.camera(), true), 40.0, 1e-4);
  EXPECT_TRUE(hasNote(p, "a pinhole has no focus"));
}

TEST(FieldOfView, ABadAxisIsNamed) {
  const test::TempDir dir;
  json j = test::minimalSceneJson();
  j["camera"] = {
      {"type", "pinhole"}, {"position", {0, 0, -3}}, {"look_at", {0, 0, 0}}, {"angle_of_view", 40}, {"fov_axis", "y"}};
  try {
    (void)test::loadSceneJson(dir, j);
    FAIL() << "fov_axis \"y\" accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(
        test::contains(e.what(), "camera.fov_axis: unknown axis \"y\" (expected horizontal, vertical, diagonal"));
  }
  j["camera"].erase("angle_of_view");
  j["camera"]["focal_length"] = 0.05;
  j["camera"]["sensor_width"] = 0.036;
  j["camera"]["fov_axis"] = "vertical";
  try {
    (void)test::loadSceneJson(dir, j);
    FAIL() << "fov_axis without angle_of_view accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(test::contains(e.what(), "camera.fov_axis: says which axis angle_of_view is measured along"));
  }
}

}  // namespace
}  // namespace lensfarm
