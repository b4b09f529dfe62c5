// Camera mistakes name their real cause: millimetre lengths in a scene in metres name the length
// and the unit (not the focus distance); look_at at the position names look_at (not the focus);
// an up along the view names up; every zero, negative, non-finite or absurd camera number names
// its own field. sensor_width may be left out with angle_of_view.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

using test::kNoError;

class BadInputCamera : public test::SceneErrorTest {
 protected:
  BadInputCamera() : SceneErrorTest("cam.json") {}

  // The minimal scene (a pinhole 3 units from a 2 x 2 quad) with `camera` merged in.
  static json withCamera(const json& camera) { return test::minimalSceneWithCamera(camera); }
};

// ---- millimetres in a scene in metres --------------------------------------------------------

TEST_F(BadInputCamera, MillimetreLensInAMetreSceneNamesTheFocalLengthAndTheUnit) {
  // A 50 mm lens on a 36 mm sensor, written in millimetres, 3 m from the subject. Today's cause
  // in the message was "focus_distance: S1 = 3 must exceed f = 50"; the field is focal_length.
  const json pinhole = withCamera({{"focal_length", 50}, {"sensor_width", 36}});
  EXPECT_TRUE(namesField(errorOf(pinhole), "camera.focal_length",
                         {"f = 50", "(3)", "not millimetres", "focal_length 0.05", "sensor_width 0.036"}));
  // The same on a thin lens with its focus distance given in metres.
  json thin = withCamera(
      {{"type", "thin_lens"}, {"focal_length", 50}, {"sensor_width", 36}, {"f_number", 2.8}, {"focus_distance", 3}});
  EXPECT_TRUE(namesField(errorOf(thin), "camera.focal_length", {"f = 50", "not millimetres", "focal_length 0.05"}));
  // Only the lens in millimetres (the sensor in metres): no advice to shrink the sensor too.
  const std::string lensOnly = errorOf(withCamera({{"focal_length", 50}, {"sensor_width", 0.036}}));
  EXPECT_TRUE(namesField(lensOnly, "camera.focal_length", {"focal_length 0.05"}));
  EXPECT_EQ(lensOnly.find("sensor_width 3.6e-05"), std::string::npos) << lensOnly;
  // The sensor in millimetres with angle_of_view: f comes from it, so it is the field to name.
  EXPECT_TRUE(namesField(errorOf(withCamera({{"focal_length", nullptr}, {"angle_of_view", 40}, {"sensor_width", 36}})),
                         "camera.sensor_width", {"angle_of_view 40", "not millimetres", "sensor_width 0.036"}));
  // The same values in metres render.
  EXPECT_EQ(errorOf(withCamera({{"focal_length", 0.05}, {"sensor_width", 0.036}})), kNoError);
  EXPECT_EQ(errorOf(withCamera({{"type", "thin_lens"},
                                {"focal_length", 0.05},
                                {"sensor_width", 0.036},
                                {"f_number", 2.8},
                                {"focus_distance", 3}})),
            kNoError);
}

TEST_F(BadInputCamera, AFocusDistanceInsideFIsStillAFocusProblem) {
  // look_at is 3 away, f = 0.1: the lens fits the scene; only the focus distance is wrong.
  const json j = withCamera({{"type", "thin_lens"}, {"f_number", 4}, {"focus_distance", 0.05}});
  EXPECT_TRUE(namesField(errorOf(j), "camera.focus_distance", {"must exceed the focal length"}));
}

// ---- sensor_width with angle_of_view ---------------------------------------------------------

TEST_F(BadInputCamera, SensorWidthIsOptionalWithAngleOfView) {
  const json j = withCamera({{"focal_length", nullptr}, {"sensor_width", nullptr}, {"angle_of_view", 60}});
  ASSERT_EQ(errorOf(j), kNoError);
  const Scene scene = test::loadSceneJson(dir_, j, "cam.json");
  EXPECT_EQ(scene.cameraParams.sensorWidth, kDefaultSensorWidth);
  EXPECT_DOUBLE_EQ(kDefaultSensorWidth, 0.036);
  EXPECT_NEAR(scene.cameraParams.focalLength, 0.036 / (2 * std::tan(std::numbers::pi / 6)), 1e-12);
  // With a thin lens too.
  EXPECT_EQ(errorOf(withCamera({{"type", "thin_lens"},
                                {"f_number", 8},
                                {"focal_length", nullptr},
                                {"sensor_width", nullptr},
                                {"angle_of_view", 60}})),
            kNoError);
  // With focal_length the pair sets the field of view: sensor_width stays required, and says why.
  EXPECT_TRUE(namesField(errorOf(withCamera({{"sensor_width", nullptr}})), "camera.sensor_width",
                         {"required with focal_length", "angle_of_view"}));
}

// ---- the frame -------------------------------------------------------------------------------

TEST_F(BadInputCamera, LookAtAtThePositionIsNotAFocusProblem) {
  for (const json& camera :
       {json{{"look_at", {0, 0, -3}}}, json{{"type", "thin_lens"}, {"f_number", 4}, {"look_at", {0, 0, -3}}},
        json{{"type", "thin_lens"}, {"f_number", 4}, {"look_at", {0, 0, -3}}, {"focus_distance", 2}},
        json{{"look_at", {0, 0, -3}}, {"focal_length", nullptr}, {"angle_of_view", 50}}}) {
    EXPECT_TRUE(namesField(errorOf(withCamera(camera)), "camera.look_at",
                           {"equals camera.position", "the view direction is undefined"}))
        << camera.dump();
  }
}

TEST_F(BadInputCamera, AnUpAlongTheViewOrZeroNamesUp) {
  // The camera looks along +z.
  for (const json& up : {json{0, 0, 1}, json{0, 0, -5}, json{0, 0, 1e-20}})
    EXPECT_TRUE(namesField(errorOf(withCamera({{"up", up}})), "camera.up", {"parallel to the view direction"}))
        << up.dump();
  EXPECT_TRUE(namesField(errorOf(withCamera({{"up", {0, 0, 0}}})), "camera.up", {"must not be [0, 0, 0]"}));
  // Tilted away from the axis a little is fine.
  EXPECT_EQ(errorOf(withCamera({{"up", {0, 0.01, 1}}})), kNoError);
}

// ---- every number ----------------------------------------------------------------------------

TEST_F(BadInputCamera, EveryDegenerateCameraNumberNamesItsField) {
  struct Field {
    std::string name;
    json base;                        // the camera fields that make `name` apply
    std::vector<std::string> values;  // JSON texts
  };
  const json thinLens = {{"type", "thin_lens"}, {"f_number", 4}, {"focus_distance", 3}};
  const json angle = {{"focal_length", nullptr}, {"angle_of_view", 50}};
  const std::vector<std::string> bad = {"0", "-1", "-0.0", "1e999", "-1e999", "\"nan\"", "\"inf\"", "null", "[1]"};
  std::vector<Field> fields = {
      {"sensor_width", json::object(), bad},
      {"sensor_height", json::object(), {"-1", "-1e-300", "1e999", "-1e999", "\"nan\"", "null"}},
      {"focal_length", json::object(), bad},
      {"angle_of_view", angle, bad},
      {"focus_distance", thinLens, bad},
      {"f_number", thinLens, {"0", "-1", "-0.0", "1e999", "-1e999", "\"nan\"", "\"-inf\"", "null", "[1]"}},
  };
  // Values too large for any camera: a field of view of 180 degrees or a focal length longer
  // than the whole scene.
  fields[0].values.push_back("1e300");
  fields[1].values.push_back("1e300");
  fields[2].values.push_back("1e300");
  fields[3].values.push_back("180");
  for (const Field& f : fields) {
    for (const std::string& v : f.values) {
      json camera = f.base;
      camera[f.name] = "@VALUE@";
      std::string text = withCamera(camera).dump(2);
      const std::string placeholder = "\"@VALUE@\"";
      text.replace(text.find(placeholder), placeholder.size(), v);
      EXPECT_TRUE(namesField(errorOfText(text), "camera." + f.name)) << f.name << " = " << v;
    }
  }
  // Vectors: non-finite (overflowing) or malformed components name the vector.
  for (const std::string name : {"position", "look_at", "up"})
    for (const std::string v :
         {"[1e999, 0, 0]", "[0, -1e999, 0]", "[0, 0, \"nan\"]", "[0, 0]", "null", "[1e39, 0, 0]"}) {
      std::string text = withCamera({{name, "@VALUE@"}}).dump(2);
      text.replace(text.find("\"@VALUE@\""), 9, v);
      // "camera.up: ..." or "camera.up[2]: ...".
      const std::string message = errorOfText(text), prefix = sceneFile().string() + ": camera." + name;
      EXPECT_EQ(message.rfind(prefix, 0), 0u) << name << " = " << v << ": " << message;
      EXPECT_TRUE(message.size() > prefix.size() && (message[prefix.size()] == ':' || message[prefix.size()] == '['))
          << message;
    }
  // look_at and position so far apart that their difference overflows single precision.
  EXPECT_TRUE(
      namesField(errorOf(withCamera({{"position", {-3e38, 0, 0}}, {"look_at", {3e38, 0, 0}}, {"up", {0, 1, 0}}})),
                 "camera.look_at"));
}

}  // namespace
}  // namespace lensfarm
