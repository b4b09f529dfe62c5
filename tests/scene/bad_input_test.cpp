// Bad scene files: every mistake a user can make is refused with an InputError whose message
// names the file and the exact field ("file: field.path: what"), never accepted or crashed on.
#include <gtest/gtest.h>

#include <filesystem>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <string>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

using test::kNoError;

// Each test gets its own directory; the scene is always written as "bad-scene.json" so that the
// message can be checked for the file.
class BadInput : public test::SceneErrorTest {
 protected:
  BadInput() : SceneErrorTest("bad-scene.json") {}

  // A thin-lens variant of the minimal scene that loads (the f_number tests start from it).
  static json thinLensScene() {
    json j = test::minimalSceneJson();
    j["camera"]["type"] = "thin_lens";
    j["camera"]["focus_distance"] = 3.0;
    j["camera"]["f_number"] = 8;
    return j;
  }

  // The minimal scene with an OBJ shape (shapes[1]) reading `objName`.
  static json withObj(const std::string& objName) {
    json j = test::minimalSceneJson();
    j["shapes"].push_back({{"type", "obj"}, {"file", objName}, {"material", "white"}});
    return j;
  }
};

// ---- positive controls: the starting points of the cases below do load ----------------------

TEST_F(BadInput, MinimalSceneLoads) {
  EXPECT_EQ(errorOf(test::minimalSceneJson()), kNoError);
  const Scene scene = test::loadSceneJson(dir_, test::minimalSceneJson());
  EXPECT_EQ(scene.render.width, 16);
  EXPECT_EQ(scene.render.samplesPerPixel, 2u);
}

TEST_F(BadInput, ControlVariantsLoad) {
  EXPECT_EQ(errorOf(thinLensScene()), kNoError);
  json focusTwiceF = test::minimalSceneJson();
  focusTwiceF["camera"]["focus_distance"] = 0.2;  // S1 = 2f: S2 = 2f, fine
  EXPECT_EQ(errorOf(focusTwiceF), kNoError);
  dir_.write("tri.obj", "g floor\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json obj = withObj("tri.obj");
  EXPECT_EQ(errorOf(obj), kNoError);
  obj["shapes"][1].erase("material");
  obj["shapes"][1]["group_materials"] = {{"floor", "white"}};
  EXPECT_EQ(errorOf(obj), kNoError);
}

// ---- the file itself ------------------------------------------------------------------------

TEST_F(BadInput, MalformedJsonNamesTheFileAndLine) {
  const std::string message = errorOfText("{\n  \"format\": \"lensfarm-scene/1\",\n  \"camera\": {\n}\n");
  EXPECT_EQ(message.rfind(sceneFile().string() + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("line"), std::string::npos) << message;
}

TEST_F(BadInput, MalformedJsonThroughParseSceneNamesTheFile) {
  try {
    (void)parseScene("{ \"format\": ", "some/dir/text-scene.json");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("some/dir/text-scene.json: ", 0), 0u) << message;
    EXPECT_NE(message.find("line"), std::string::npos) << message;
  }
}

TEST_F(BadInput, MissingFormat) {
  json j = test::minimalSceneJson();
  j.erase("format");
  EXPECT_TRUE(namesField(errorOf(j), "format"));
}

TEST_F(BadInput, WrongFormat) {
  json j = test::minimalSceneJson();
  j["format"] = "lensfarm-scene/2";
  EXPECT_TRUE(namesField(errorOf(j), "format", {"lensfarm-scene/2"}));
}

// ---- materials ------------------------------------------------------------------------------

TEST_F(BadInput, UnknownMaterialType) {
  json j = test::minimalSceneJson();
  j["materials"]["white"]["type"] = "lambertain";
  EXPECT_TRUE(namesField(errorOf(j), "materials.white.type", {"lambertain"}));
}

TEST_F(BadInput, ReferenceToUndefinedMaterial) {
  json j = test::minimalSceneJson();
  j["shapes"][0]["material"] = "whte";
  EXPECT_TRUE(namesField(errorOf(j), "shapes[0].material", {"whte"}));
}

// ---- misspelled fields ----------------------------------------------------------------------

TEST_F(BadInput, UnknownFieldAtTopLevel) {
  json j = test::minimalSceneJson();
  j["light"] = json::array();
  EXPECT_TRUE(namesField(errorOf(j), "light", {"unknown field"}));
}

TEST_F(BadInput, UnknownFieldInCamera) {
  json j = test::minimalSceneJson();
  j["camera"]["focus_distanse"] = 3.0;
  EXPECT_TRUE(namesField(errorOf(j), "camera.focus_distanse", {"unknown field"}));
}

TEST_F(BadInput, UnknownFieldInMaterial) {
  json j = test::minimalSceneJson();
  j["materials"]["white"]["emision"] = 1.0;
  EXPECT_TRUE(namesField(errorOf(j), "materials.white.emision", {"unknown field"}));
}

TEST_F(BadInput, UnknownFieldInRender) {
  json j = test::minimalSceneJson();
  j["render"]["sampels_per_pixel"] = 4;
  EXPECT_TRUE(namesField(errorOf(j), "render.sampels_per_pixel", {"unknown field"}));
}

// ---- OBJ assets -----------------------------------------------------------------------------

TEST_F(BadInput, MissingObjFile) {
  EXPECT_TRUE(namesField(errorOf(withObj("no-such-mesh.obj")), "shapes[1].file", {"no-such-mesh.obj"}));
}

TEST_F(BadInput, ObjFaceRefersToMissingVertex) {
  dir_.write("holey.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  EXPECT_TRUE(namesField(errorOf(withObj("holey.obj")), "shapes[1].file", {"holey.obj"}));
}

TEST_F(BadInput, GroupMaterialsNamingAGroupTheObjDoesNotHave) {
  dir_.write("tri.obj", "g floor\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json j = withObj("tri.obj");
  j["shapes"][1].erase("material");
  j["shapes"][1]["group_materials"] = {{"floor", "white"}, {"celing", "white"}};
  EXPECT_TRUE(namesField(errorOf(j), "shapes[1].group_materials.celing"));
}

// ---- numbers and vectors --------------------------------------------------------------------

TEST_F(BadInput, OverflowingNumberIsNotAcceptedAsInfinity) {
  json j = test::minimalSceneJson();
  j["camera"]["focal_length"] = "@NUMBER@";
  std::string text = j.dump(2);
  const std::string placeholder = "\"@NUMBER@\"";
  text.replace(text.find(placeholder), placeholder.size(), "1e999");
  const std::string message = errorOfText(text);
  EXPECT_EQ(message.rfind(sceneFile().string() + ": ", 0), 0u) << "not an InputError naming the file: " << message;
  EXPECT_TRUE(namesField(message, "camera.focal_length"));
}

TEST_F(BadInput, Vec3WithTwoElements) {
  json j = test::minimalSceneJson();
  j["camera"]["position"] = {0, 0};
  EXPECT_TRUE(namesField(errorOf(j), "camera.position"));
}

// ---- the camera -----------------------------------------------------------------------------

TEST_F(BadInput, FocusDistanceInsideFocalLength) {
  json j = test::minimalSceneJson();
  j["camera"]["type"] = "thin_lens";  // a lens: a pinhole has no focus
  j["camera"]["f_number"] = 8;
  j["camera"]["focus_distance"] = 0.05;  // f = 0.1
  EXPECT_TRUE(namesField(errorOf(j), "camera.focus_distance"));
  j["camera"]["focus_distance"] = 0.1;  // S1 == f
  EXPECT_TRUE(namesField(errorOf(j), "camera.focus_distance"));
}

TEST_F(BadInput, FocusDistanceBarelyBeyondFocalLengthMakesS2Unbounded) {
  json j = test::minimalSceneJson();
  j["camera"]["type"] = "thin_lens";
  j["camera"]["f_number"] = 8;
  const double f = j["camera"]["focal_length"].get<double>();
  j["camera"]["focus_distance"] = f * (1.0 + 1e-9);
  ASSERT_GT(j["camera"]["focus_distance"].get<double>(), f);
  EXPECT_TRUE(namesField(errorOf(j), "camera.focus_distance"));
}

TEST_F(BadInput, ZeroSensorWidth) {
  json j = test::minimalSceneJson();
  j["camera"]["sensor_width"] = 0;
  EXPECT_TRUE(namesField(errorOf(j), "camera.sensor_width"));
}

TEST_F(BadInput, ZeroFNumber) {
  json j = thinLensScene();
  j["camera"]["f_number"] = 0;
  EXPECT_TRUE(namesField(errorOf(j), "camera.f_number"));
}

TEST_F(BadInput, NonNumericFNumber) {
  json j = thinLensScene();
  j["camera"]["f_number"] = "abc";
  EXPECT_TRUE(namesField(errorOf(j), "camera.f_number"));
}

TEST_F(BadInput, BothFocalLengthAndAngleOfView) {
  json j = test::minimalSceneJson();
  j["camera"]["angle_of_view"] = 60;
  EXPECT_TRUE(namesField(errorOf(j), "camera.focal_length", {"angle_of_view"}));
}

// ---- render settings ------------------------------------------------------------------------

TEST_F(BadInput, ResolutionOutOfRange) {
  for (const json& res : {json{0, 10}, json{10, 0}, json{100000, 10}, json{-4, 10}}) {
    json j = test::minimalSceneJson();
    j["render"]["resolution"] = res;
    EXPECT_TRUE(namesField(errorOf(j), "render.resolution")) << res.dump();
  }
}

TEST_F(BadInput, ResolutionNotIntegers) {
  for (const json& res : {json{16.5, 16}, json{16, 0.5}, json{"16", "16"}, json::array({16}), json{16, 16, 16}}) {
    json j = test::minimalSceneJson();
    j["render"]["resolution"] = res;
    EXPECT_TRUE(namesField(errorOf(j), "render.resolution")) << res.dump();
  }
}

TEST_F(BadInput, ZeroSamplesPerPixel) {
  json j = test::minimalSceneJson();
  j["render"]["samples_per_pixel"] = 0;
  EXPECT_TRUE(namesField(errorOf(j), "render.samples_per_pixel"));
}

TEST_F(BadInput, MaxBouncesOutOfRange) {
  for (const int bounces : {-1, 5000}) {
    json j = test::minimalSceneJson();
    j["render"]["max_bounces"] = bounces;
    EXPECT_TRUE(namesField(errorOf(j), "render.max_bounces")) << bounces;
  }
}

// ---- an empty scene -------------------------------------------------------------------------

TEST_F(BadInput, EmptyShapesHasNoTriangles) {
  json j = test::minimalSceneJson();
  j["shapes"] = json::array();
  EXPECT_TRUE(namesField(errorOf(j), "shapes", {"no triangles"}));
}

TEST_F(BadInput, EmptyShapesAndNoLightsHasNoTriangles) {
  json j = test::minimalSceneJson();
  j["shapes"] = json::array();
  j.erase("lights");
  EXPECT_TRUE(namesField(errorOf(j), "shapes", {"no triangles"}));
}

TEST(BadInputLimits, DeepNestingIsRefusedBeforeParsing) {
  std::string text = "{\"format\": \"lensfarm-scene/1\", \"x\": ";
  text += std::string(100000, '[') + std::string(100000, ']') + "}";
  try {
    parseScene(text, "deep.json");
    FAIL() << "a 100000-deep scene must be refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("deep.json: line 1: nested deeper than 64"), std::string::npos) << e.what();
  }
  // Brackets inside strings (escaped quotes too) do not count.
  json j = test::minimalSceneJson();
  j["materials"][std::string("\"") + std::string(200, '[')] = {{"type", "lambertian"}, {"albedo", 0.5}};
  EXPECT_NO_THROW(parseScene(j.dump(), "fine.json"));
}

}  // namespace
}  // namespace lensfarm
