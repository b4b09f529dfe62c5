// Keyframes in the scene file (scene/keyframes.h, docs/scene-format.md "Animation"): values at,
// between and beyond keyframes against hand-computed ones (a camera moving linearly, a quarter
// turn that is an eighth turn half-way); slerp keeps unit length and takes the shorter arc; a
// keyframed shape at a frame is bit for bit the static shape with that transform written by
// hand; a still scene loads as before; every bad keyframe names its field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "common/scene/keyframes.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// The minimal scene (a pinhole 3 units in front of a 2 x 2 quad) with `camera` merged in and
// `shape` (if any) added after the quad.
json sceneWith(const json& camera, const json& shape = nullptr) {
  json j = test::minimalSceneWithCamera(camera);
  if (!shape.is_null()) j["shapes"].push_back(shape);
  return j;
}

Scene parseAt(const json& scene, std::optional<double> frame) {
  return parseScene(scene.dump(), "anim.json", {}, frame);
}

// A camera dollying from z = -3 at frame 1 to z = -1 at frame 11, looking at the origin.
json dollyScene() {
  return sceneWith(
      {{"position", nullptr},
       {"keyframes", {{{"frame", 1}, {"position", {0, 0, -3}}}, {{"frame", 11}, {"position", {0, 0, -1}}}}}});
}

TEST(Animation, CameraMovesLinearlyBetweenKeyframesAndHoldsBeyondThem) {
  const json scene = dollyScene();
  // (frame, expected z): held before frame 1 and after frame 11; z = -3 + 2 (F - 1) / 10 between.
  for (const auto& [frame, z] : std::vector<std::pair<double, double>>{
           {-5, -3}, {1, -3}, {3.5, -2.5}, {6, -2}, {8.5, -1.5}, {11, -1}, {40, -1}}) {
    SCOPED_TRACE(frame);
    const Scene s = parseAt(scene, frame);
    EXPECT_TRUE(s.animated());
    EXPECT_EQ(s.frame, frame);
    EXPECT_DOUBLE_EQ(s.origin.z, z);  // the camera's world position
    EXPECT_EQ(s.origin.x, 0.0);
    // look_at stays at the world origin: in render space it is -position (a pinhole: no focus).
    EXPECT_FLOAT_EQ(s.cameraParams.lookAt.z, float(-z));
  }
  // Without a frame: the first keyframe's.
  const Scene first = parseAt(scene, std::nullopt);
  ASSERT_TRUE(first.keyframeRange);
  EXPECT_EQ(first.keyframeRange->first, 1.0);
  EXPECT_EQ(first.keyframeRange->last, 11.0);
  EXPECT_EQ(first.frame, 1.0);
  EXPECT_EQ(first.origin.z, -3.0);
}

TEST(Animation, LensNumbersInterpolateLinearlyPerTrack) {
  // f_number keyed at frames 0 and 10, focus_distance at 5 and 15: each track on its own.
  const json scene = sceneWith({{"type", "thin_lens"},
                                {"keyframes",
                                 {{{"frame", 0}, {"f_number", 2}},
                                  {{"frame", 5}, {"focus_distance", 1}},
                                  {{"frame", 10}, {"f_number", 8}},
                                  {{"frame", 15}, {"focus_distance", 3}}}}});
  const Scene at0 = parseAt(scene, 0), at5 = parseAt(scene, 5), at10 = parseAt(scene, 10), at20 = parseAt(scene, 20);
  EXPECT_EQ(at0.cameraParams.fNumber, 2.0);
  EXPECT_EQ(at0.cameraParams.focusDistance, 1.0);  // held before its first keyframe (5)
  EXPECT_EQ(at5.cameraParams.fNumber, 5.0);        // half-way from 2 to 8
  EXPECT_EQ(at5.cameraParams.focusDistance, 1.0);
  EXPECT_EQ(at10.cameraParams.fNumber, 8.0);
  EXPECT_EQ(at10.cameraParams.focusDistance, 2.0);  // half-way from 1 to 3
  EXPECT_EQ(at20.cameraParams.focusDistance, 3.0);
  EXPECT_EQ(at0.keyframeRange->first, 0.0);
  EXPECT_EQ(at0.keyframeRange->last, 15.0);
}

TEST(Animation, SlerpOfAQuarterTurnIsAnEighthTurnHalfWay) {
  TransformParts none, quarter;
  quarter.rotates = true;
  quarter.axis = DVec3(0, 0, 1);
  quarter.radians = std::numbers::pi / 2;
  const TransformParts half = interpolateTransform(none, quarter, 0.5);
  ASSERT_TRUE(half.rotates);
  EXPECT_NEAR(half.radians, std::numbers::pi / 4, 1e-15);
  EXPECT_NEAR(half.axis.z, 1.0, 1e-15);
  // A quarter of the way: 22.5 degrees; slerp has constant angular speed.
  EXPECT_NEAR(interpolateTransform(none, quarter, 0.25).radians, std::numbers::pi / 8, 1e-15);
  // 0 to 270 degrees goes the shorter way: -90, so -45 half-way (about -z, at +45).
  TransformParts threeQuarters = quarter;
  threeQuarters.radians = 3 * std::numbers::pi / 2;
  const TransformParts back = interpolateTransform(none, threeQuarters, 0.5);
  EXPECT_NEAR(back.radians, std::numbers::pi / 4, 1e-15);
  EXPECT_NEAR(back.axis.z, -1.0, 1e-15);
}

TEST(Animation, SlerpKeepsUnitLength) {
  std::mt19937_64 rng(24);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    TransformParts a, b;
    a.rotates = b.rotates = true;
    a.axis = glm::normalize(DVec3(u(rng), u(rng), u(rng)));
    b.axis = glm::normalize(DVec3(u(rng), u(rng), u(rng)));
    a.radians = 3.0 * u(rng), b.radians = trial % 10 == 0 ? a.radians + 1e-9 : 3.0 * u(rng);  // some nearly equal
    for (double t : {0.1, 0.37, 0.5, 0.9}) {
      const TransformParts m = interpolateTransform(a, b, t);
      ASSERT_TRUE(m.rotates);
      EXPECT_NEAR(glm::length(m.axis), 1.0, 1e-14);
      EXPECT_NEAR(glm::length(m.quaternion()), 1.0, 1e-14);
      // A rotation matrix: orthonormal, determinant 1.
      const glm::dmat3 r(m.matrix());
      EXPECT_NEAR(glm::determinant(r), 1.0, 1e-13);
      const glm::dmat3 rtr = glm::transpose(r) * r;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) EXPECT_NEAR(rtr[i][j], i == j ? 1.0 : 0.0, 1e-13);
    }
  }
}

// The positions of every mesh of a scene, for bitwise comparison.
std::vector<Vec3> allPositions(const Scene& s) {
  std::vector<Vec3> out;
  for (const TriangleMesh& m : s.meshes) out.insert(out.end(), m.positions.begin(), m.positions.end());
  return out;
}

void expectSameBits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)), 0);
}

TransformParts readParts(const json& transform) {
  const json holder = {{"transform", transform}};
  const std::string file = "test";
  FieldReader r(holder, "", file);
  return readTransformParts(r, "transform");
}

// A triangle shape (in front of the quad) with `transform` or `keyframes`.
json triangleShape(const char* key, const json& value) {
  return {{"type", "triangles"},
          {"material", "white"},
          {"vertices", {{-0.5, -0.5, -1}, {0.5, -0.5, -1}, {0, 0.5, -1.2}}},
          {key, value}};
}

TEST(Animation, KeyframedShapeIsBitForBitTheStaticShapeWrittenByHand) {
  const json rotated = {
      {"scale", 1.5}, {"rotate", {{"axis", {1, 2, 3}}, {"degrees", 33}}}, {"translate", {0.1, 0.2, 0.3}}};
  const json keys = {
      {{"frame", 1}, {"transform", {{"rotate", {{"axis", {0, 1, 0}}, {"degrees", 30}}}}}},
      {{"frame", 5},
       {"transform", {{"scale", 1}, {"rotate", {{"axis", {0, 1, 0}}, {"degrees", 30}}}, {"translate", {0, 0, 0}}}}},
      {{"frame", 9},
       {"transform", {{"scale", 3}, {"rotate", {{"axis", {0, 1, 0}}, {"degrees", 30}}}, {"translate", {2, 4, 6}}}}},
      {{"frame", 12}, {"transform", rotated}}};
  const json animated = sceneWith(json::object(), triangleShape("keyframes", keys));
  const auto expectStatic = [&](double frame, const json& transform) {
    SCOPED_TRACE(frame);
    expectSameBits(
        allPositions(parseAt(animated, frame)),
        allPositions(parseAt(sceneWith(json::object(), triangleShape("transform", transform)), std::nullopt)));
  };
  expectStatic(0, keys[0]["transform"]);  // held before
  expectStatic(1, keys[0]["transform"]);
  // Half-way from frame 5 to 9: scale 2, translate [1, 2, 3], the unchanged rotation as written.
  expectStatic(7, {{"scale", 2}, {"rotate", {{"axis", {0, 1, 0}}, {"degrees", 30}}}, {"translate", {1, 2, 3}}});
  expectStatic(12, rotated);   // at a keyframe with a rotation of its own
  expectStatic(100, rotated);  // held after
  // Between 9 and 12 the rotation is slerped: close to, not bit for bit, a hand computation.
  const Scene between = parseAt(animated, 10.5);
  ASSERT_EQ(between.meshes.size(), 3u);  // the quad, the triangle, the light
  const glm::dmat4 m = interpolateTransform(readParts(keys[2]["transform"]), readParts(rotated), 0.5).matrix();
  const Vec3 v0 = between.meshes[1].positions[0];
  const DVec3 expected = DVec3(m * glm::dvec4(-0.5, -0.5, -1, 1)) + DVec3(0, 0, 3);  // render space: less the camera
  EXPECT_NEAR(glm::distance(DVec3(v0), expected), 0.0, 1e-6);
  EXPECT_GT(glm::distance(DVec3(v0), DVec3(allPositions(parseAt(animated, 9))[4])), 0.1);  // it moved
}

TEST(Animation, ShapeRotatedAQuarterTurnIsAnEighthTurnHalfWay) {
  // A quad keyed from 0 to 90 degrees about z over frames 0-10: at frame 5 its corner
  // (1, 0, 0) is at (cos 45, sin 45, 0).
  const json keys = {{{"frame", 0}, {"transform", {{"rotate", {{"axis", {0, 0, 1}}, {"degrees", 0}}}}}},
                     {{"frame", 10}, {"transform", {{"rotate", {{"axis", {0, 0, 1}}, {"degrees", 90}}}}}}};
  const json quad = {{"type", "quad"},       {"material", "white"},   {"corner", {1, 0, -1}},
                     {"edge1", {0, 0.5, 0}}, {"edge2", {-0.5, 0, 0}}, {"keyframes", keys}};
  const Scene s = parseAt(sceneWith(json::object(), quad), 5);
  ASSERT_EQ(s.meshes.size(), 3u);  // the quad, this quad, the light
  const Vec3 corner = s.meshes[1].positions[0];
  const double c = std::sqrt(0.5);
  // Render space: the world less the camera's position (0, 0, -3).
  EXPECT_NEAR(corner.x, c, 1e-6);
  EXPECT_NEAR(corner.y, c, 1e-6);
  EXPECT_NEAR(corner.z, 2.0, 1e-6);
}

TEST(Animation, ModelsAndQuadLightsAnimateToo) {
  test::TempDir dir;
  dir.write("tri.obj", "v -0.5 -0.5 -1\nv 0.5 -0.5 -1\nv 0 0.5 -1.2\nf 1 2 3\n");
  const json moved = {{"translate", {0.25, 0.5, 0}}};
  json objShape = {{"type", "obj"}, {"file", "tri.obj"}, {"material", "white"}};
  json animated = sceneWith(json::object(), objShape);
  animated["shapes"][1]["keyframes"] = {{{"frame", 0}, {"transform", json::object()}},
                                        {{"frame", 2}, {"transform", {{"translate", {0.5, 1, 0}}}}}};
  animated["lights"][0].erase("corner");
  animated["lights"][0]["keyframes"] = {{{"frame", 0}, {"corner", {-0.5, -0.5, -1}}},
                                        {{"frame", 2}, {"corner", {-0.5, -0.25, -1}}}};
  json still = sceneWith(json::object(), objShape);
  still["shapes"][1]["transform"] = moved;
  still["lights"][0]["corner"] = {-0.5, -0.375, -1};
  dir.write("animated.json", animated.dump());
  dir.write("still.json", still.dump());
  expectSameBits(allPositions(loadScene(dir / "animated.json", 1.0)), allPositions(loadScene(dir / "still.json")));
}

TEST(Animation, StillScenesLoadAsBeforeAndTheHashIsTheFilesForEveryFrame) {
  const json still = test::minimalSceneJson();
  const Scene plain = parseAt(still, std::nullopt), atFrame = parseAt(still, 17);
  EXPECT_FALSE(plain.animated());
  EXPECT_FALSE(atFrame.animated());
  EXPECT_EQ(plain.hash, atFrame.hash);
  expectSameBits(allPositions(plain), allPositions(atFrame));
  // An animated scene: one hash for every frame (a frame of a job is (hash, frame)), not that of
  // the scene it evaluates to.
  const json dolly = dollyScene();
  EXPECT_EQ(parseAt(dolly, 1).hash, parseAt(dolly, 7).hash);
  EXPECT_NE(parseAt(dolly, 1).hash, plain.hash);
}

TEST(Animation, TheShippedAnimatedCornellBoxDolliesAndTurns) {
  const Scene first = loadScene(test::scenesDir() / "cornell-animated.json");
  ASSERT_TRUE(first.animated());
  EXPECT_EQ(first.keyframeRange->first, 1.0);
  EXPECT_EQ(first.keyframeRange->last, 24.0);
  const Scene last = loadScene(test::scenesDir() / "cornell-animated.json", 24.0);
  EXPECT_DOUBLE_EQ(first.origin.z, -3.6);
  EXPECT_DOUBLE_EQ(last.origin.z, -2.5);
  // The walls are the same in the world: in render space they move by the dolly.
  EXPECT_NE(allPositions(first), allPositions(last));
}

// ---- bad keyframes -----------------------------------------------------------------------------

class BadKeyframes : public test::SceneErrorTest {
 protected:
  BadKeyframes() : SceneErrorTest("anim.json") {}
  std::string cameraKeys(const json& keys) const {
    return errorOf(sceneWith({{"keyframes", keys}, {"position", nullptr}}));
  }
  std::string shapeKeys(const json& keys) const {
    return errorOf(sceneWith(json::object(), triangleShape("keyframes", keys)));
  }
};

TEST_F(BadKeyframes, EachNamesItsField) {
  EXPECT_TRUE(namesField(cameraKeys(json::array()), "camera.keyframes", {"non-empty array"}));
  EXPECT_TRUE(namesField(cameraKeys({{"frame", 1}}), "camera.keyframes", {"non-empty array"}));  // an object
  const json p = {0, 0, -3};
  EXPECT_TRUE(namesField(
      cameraKeys({{{"frame", 1}, {"position", p}}, {{"frame", 5}, {"position", p}}, {{"frame", 3}, {"position", p}}}),
      "camera.keyframes[2].frame", {"3 is not after", "frame 5", "strictly increasing"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"frame", 1}, {"position", p}}, {{"frame", 1}, {"position", p}}}),
                         "camera.keyframes[1].frame", {"not after"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"position", p}}}), "camera.keyframes[0].frame", {"is required"}));
  EXPECT_TRUE(
      namesField(cameraKeys({{{"frame", "one"}, {"position", p}}}), "camera.keyframes[0].frame", {"must be a number"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"frame", 1}, {"position", p}}, {{"frame", 2}, {"zoom", 2}}}),
                         "camera.keyframes[1].zoom", {"unknown field", "position", "f_number"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"frame", 1}}}), "camera.keyframes[0]", {"gives no property", "look_at"}));
  EXPECT_TRUE(
      namesField(cameraKeys({{{"frame", 1}, {"position", {0, 0}}}}), "camera.keyframes[0].position", {"3 numbers"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"frame", 1}, {"position", p}, {"focal_length", -1}}}),
                         "camera.keyframes[0].focal_length", {"> 0"}));
  EXPECT_TRUE(namesField(cameraKeys({{{"frame", 1}, {"position", p}, {"angle_of_view", 180}}}),
                         "camera.keyframes[0].angle_of_view"));
  // A property both static and keyframed.
  EXPECT_TRUE(namesField(errorOf(sceneWith({{"keyframes", {{{"frame", 1}, {"look_at", {0, 0, 0}}}}}})),
                         "camera.look_at", {"keyframed too", "camera.keyframes"}));
  // Numbers too large for a double (JSON allows 1e999) name the keyframe's field.
  std::string text =
      sceneWith({{"keyframes", {{{"frame", 1}, {"position", {7, 0, -3}}}}}, {"position", nullptr}}).dump();
  text.replace(text.find("7,0,-3"), 1, "1e999");
  EXPECT_TRUE(namesField(errorOfText(text), "camera.keyframes[0].position[0]", {"finite"}));
}

TEST_F(BadKeyframes, ShapeAndLightKeyframesNameTheirFields) {
  const json t = {{"translate", {0, 0, 0}}};
  EXPECT_TRUE(namesField(shapeKeys({{{"frame", 0}, {"transform", {{"scale", {1, 0, 1}}}}}}),
                         "shapes[1].keyframes[0].transform.scale", {"must not be zero"}));
  EXPECT_TRUE(namesField(shapeKeys({{{"frame", 0}, {"transform", {{"scale", 1}}}},
                                    {{"frame", 4}, {"transform", {{"scale", {1, -1, 1}}}}}}),
                         "shapes[1].keyframes[1].transform.scale", {"changes sign", "keyframes[0]", "zero"}));
  EXPECT_TRUE(
      namesField(shapeKeys({{{"frame", 0}, {"transform", {{"rotate", {{"axis", {0, 0, 0}}, {"degrees", 9}}}}}}}),
                 "shapes[1].keyframes[0].transform.rotate.axis", {"must not be zero"}));
  EXPECT_TRUE(namesField(shapeKeys({{{"frame", 0}, {"translate", {1, 0, 0}}}}), "shapes[1].keyframes[0].translate",
                         {"unknown field", "transform"}));
  EXPECT_TRUE(
      namesField(shapeKeys({{{"frame", 0}, {"transform", {{"shear", 1}}}}}), "shapes[1].keyframes[0].transform.shear"));
  json both = sceneWith(json::object(), triangleShape("transform", t));
  both["shapes"][1]["keyframes"] = {{{"frame", 0}, {"transform", t}}};
  EXPECT_TRUE(namesField(errorOf(both), "shapes[1].transform", {"keyframed too"}));
  json sun = test::minimalSceneJson();
  sun["lights"].push_back(
      {{"type", "directional"}, {"direction", {0, 1, 0}}, {"irradiance", 1}, {"keyframes", {{{"frame", 0}}}}});
  EXPECT_TRUE(namesField(errorOf(sun), "lights[1].keyframes", {"directional light cannot be keyframed"}));
  json lamp = test::minimalSceneJson();
  lamp["lights"][0]["keyframes"] = {{{"frame", 0}, {"radiance", 2}}};
  EXPECT_TRUE(namesField(errorOf(lamp), "lights[0].keyframes[0].radiance", {"unknown field", "corner", "edge1"}));
  // Environment and materials take no keyframes: the usual unknown-field error.
  json sky = test::minimalSceneJson();
  sky["environment"] = {{"radiance", 1}, {"keyframes", json::array()}};
  EXPECT_TRUE(namesField(errorOf(sky), "environment.keyframes", {"unknown field"}));
}

TEST_F(BadKeyframes, AnEvaluatedCameraIsCheckedLikeAWrittenOne) {
  // look_at passes through the camera's position at frame 5: that frame names camera.look_at,
  // the others load.
  const json scene =
      sceneWith({{"look_at", nullptr},
                 {"keyframes", {{{"frame", 0}, {"look_at", {0, 0, -4}}}, {{"frame", 10}, {"look_at", {0, 0, -2}}}}}});
  EXPECT_NO_THROW(parseAt(scene, 4));
  try {
    parseAt(scene, 5);
    ADD_FAILURE() << "frame 5 loaded";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("anim.json: camera.look_at: equals camera.position", 0), 0u) << e.what();
  }
  EXPECT_THROW(parseAt(scene, std::numeric_limits<double>::quiet_NaN()), InputError);
}

}  // namespace
}  // namespace lensfarm
