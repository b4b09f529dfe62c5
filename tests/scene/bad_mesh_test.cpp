// Bad meshes: whatever bytes a scene names as "obj" that are not an OBJ with faces (an empty
// file, glTF, random bytes, an image, an OBJ with only vertices, ...) are refused with one
// InputError naming the scene, the mesh entry, the mesh file and the reason; never loaded as a
// mesh with no triangles (the object silently missing). OBJ files as they come from real
// exporters still load, with every triangle.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "common/scene/obj_check.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class BadInputMesh : public test::SceneErrorTest {
 protected:
  BadInputMesh() : SceneErrorTest("scene.json") {}
  std::string meshPath(const std::string& name) const { return (dir_ / name).string(); }

  // The minimal scene plus shapes[1], an OBJ shape reading `name`.
  static json sceneWith(const std::string& name) {
    json j = test::minimalSceneJson();
    j["shapes"].push_back({{"type", "obj"}, {"file", name}, {"material", "white"}});
    return j;
  }

  // Writes `bytes` as the mesh and loads the scene: the InputError's message, or kNoError.
  std::string errorOfMesh(const std::string& bytes, const std::string& name = "mesh.obj") const {
    dir_.write(name, bytes);
    return errorOf(sceneWith(name));
  }

  // "<scene>: shapes[1].file: "<mesh path>": <reason...>" with `reason` in it.
  ::testing::AssertionResult refusedNamingTheFile(const std::string& message, const std::string& name,
                                                  const std::string& reason) const {
    const std::string prefix = sceneFile().string() + ": shapes[1].file: \"" + meshPath(name) + "\": ";
    if (message.rfind(prefix, 0) != 0)
      return ::testing::AssertionFailure() << "message \"" << message << "\" does not start with \"" << prefix << "\"";
    if (message.find(reason) == std::string::npos)
      return ::testing::AssertionFailure() << "message \"" << message << "\" does not contain \"" << reason << "\"";
    return ::testing::AssertionSuccess();
  }

  // The OBJ's triangles after loading (shapes[1] is mesh "obj#1").
  size_t trianglesOf(const std::string& objText) const {
    dir_.write("good.obj", objText);
    const Scene scene = test::loadSceneJson(dir_, sceneWith("good.obj"), "scene.json");
    for (const auto& m : scene.meshes)
      if (m.name == "obj#1") return m.triangleCount();
    return 0;
  }
};

const std::string kTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

TEST_F(BadInputMesh, EveryKindOfNonObjIsRefusedWithTheFileAndTheReason) {
  const std::string png("\x89PNG\r\n\x1A\n\0\0\0\rIHDR\0\0\0\x10\0\0\0\x10\x08\x02\0\0\0\x90\x91h6", 33);
  const std::string glb = std::string("glTF\x02\0\0\0", 8) + std::string("\x40\0\0\0JSON", 8) + "{\"asset\":{}}";
  const std::string gltf = R"({ "asset": { "version": "2.0", "generator": "Blender" },
    "meshes": [ { "primitives": [ { "attributes": { "POSITION": 0 } } ] } ] })";
  struct Case {
    std::string name, bytes, reason;
  };
  const std::vector<Case> cases = {
      {"empty.obj", "", "empty file"},
      {"blank.obj", " \n\t\r\n   \n", "empty file (only whitespace)"},
      {"bom-only.obj", "\xEF\xBB\xBF\n", "empty file"},
      {"comments.obj", "# exported by nothing\n# at all\n", "no faces"},
      {"nul.obj", kTriangle + std::string("f 1 2 3\n\0\0\0\0", 12), "binary data"},
      {"ctrl.obj", "v 0 0 0\x01\x02\x03\n", "binary data"},
      {"model.glb", glb, "glTF"},
      {"glb-as.obj", glb, "give it as a glTF shape"},
      {"model.gltf", gltf, "this is a glTF file (JSON), not OBJ"},
      {"image.png", png, "PNG image"},
      {"scene-as-mesh.obj", test::minimalSceneJson().dump(), "JSON file"},
      {"page.obj", "<!DOCTYPE html>\n<html><body>404</body></html>\n", "HTML"},
      {"mesh.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "PLY"},
      {"mesh.stl", "solid cube\n facet normal 0 0 1\n", "STL"},
      {"archive.obj", std::string("PK\x03\x04\x14\0\0\0", 8), "ZIP"},
      {"only-vertices.obj", kTriangle, "no faces: 3 vertices"},
      {"only-lines.obj", kTriangle + "l 1 2 3\np 1\n", "no faces"},
      {"out-of-range.obj", kTriangle + "f 1 2 4\n", "line 4: face refers to vertex 4, but only 3 vertices"},
      {"far-out-of-range.obj", kTriangle + "f 1 2 3\nf 1 2 999999999999\n",
       "line 5: face refers to vertex 999999999999"},
      {"negative-out-of-range.obj", kTriangle + "f -1 -2 -4\n", "face refers to vertex -4"},
      {"forward-reference.obj", "f 1 2 3\n" + kTriangle, "line 1: face refers to vertex 1, but no vertex is"},
      {"zero-index.obj", kTriangle + "f 0 1 2\n", "line 4: '0' is not a vertex reference"},
      {"bad-reference.obj", kTriangle + "f 1/2/3/4 2 3\n", "'1/2/3/4' is not a vertex reference"},
      {"two-vertex-face.obj", kTriangle + "f 1 2\n", "line 4: a face needs at least 3 vertices"},
      {"unknown.obj", kTriangle + "xyz 1 2 3\nf 1 2 3\n", "line 4: 'xyz' is not an OBJ statement"},
      {"readme.obj", "lensfarm renders scenes\n", "line 1: 'lensfarm' is not an OBJ statement"},
      {"decimal-comma.obj", "v 0 0 0\nv 1,5 0 0\nv 0 1 0\nf 1 2 3\n", "line 2: '1,5' is not a finite number"},
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "line 2: 'nan' is not a finite number"},
      {"short-vertex.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1: a vertex is 'v x y z'"},
  };
  for (const Case& c : cases) {
    const std::string message = errorOfMesh(c.bytes, c.name);
    EXPECT_TRUE(refusedNamingTheFile(message, c.name, c.reason)) << c.name;
  }
}

TEST_F(BadInputMesh, RandomBytesAreRefusedNamingTheFile) {
  std::mt19937_64 rng(18);
  for (int k = 0; k < 300; ++k) {
    const size_t size = 1 + rng() % (k < 100 ? 16 : 4096);
    std::string bytes(size, '\0');
    const bool printable = k % 3 == 0;  // random text too, not only random binary
    for (char& c : bytes) c = char(printable ? 0x20 + rng() % 95 : rng() % 256);
    const std::string message = errorOfMesh(bytes, "random.obj");
    const std::string prefix = sceneFile().string() + ": shapes[1].file: \"" + meshPath("random.obj") + "\": ";
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << "case " << k << ": " << message;
  }
}

TEST_F(BadInputMesh, ObjFilesFromRealExportersLoadWithEveryTriangle) {
  // Blender-style: comments, mtllib, o, vt, vn, s, usemtl, faces v/vt/vn.
  EXPECT_EQ(trianglesOf("# Blender 4.1\nmtllib cube.mtl\no Plane\nv -1 0 1\nv 1 0 1\nv -1 0 -1\nv 1 0 -1\n"
                        "vn -0 1 -0\nvt 1 0\nvt 0 1\nvt 0 0\nvt 1 1\ns 0\nusemtl Material\n"
                        "f 2/1/1 3/2/1 1/3/1\nf 2/1/1 4/4/1 3/2/1\n"),
            2u);
  // CRLF line endings, tabs, trailing whitespace, groups and v//vn and v/vt faces.
  EXPECT_EQ(trianglesOf("g\tfloor \r\nv 0 0 0 \r\nv\t1\t0\t0\r\nv 0 1 0\t\r\nvn 0 0 1\r\nvt 0 0\r\n"
                        "f 1//1 2//1 3//1  \r\nf 1/1 2/1 3/1\r\n"),
            2u);
  // Old Mac CR-only line endings.
  EXPECT_EQ(trianglesOf("v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r"), 1u);
  // Negative (relative) indices, a quad and a pentagon (triangulated), w and colour on vertices.
  EXPECT_EQ(trianglesOf("v 0 0 0 1\nv 1 0 0 1\nv 1 1 0 1\nv 0 1 0 1\nf -4 -3 -2 -1\n"
                        "v 0 0 1 0.5 0.5 0.5\nv 1 0 1 0.5 0.5 0.5\nv 1.5 0.5 1 0.5 0.5 0.5\nv 1 1 1 0.5 0.5 0.5\nv 0 1 "
                        "1 0.5 0.5 0.5\n"
                        "f 5 6 7 8 9\n"),
            5u);
  // A UTF-8 byte-order mark: the first vertex is not lost (tinyobjloader alone skips that line).
  EXPECT_EQ(trianglesOf("\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), 1u);
  // A statement continued with a backslash; a comment ending in one does not continue.
  EXPECT_EQ(trianglesOf("# C:\\models\\\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 \\\n  3\nf 2 4 \\\r\n3\n"), 2u);
  // Points, lines, free-form and display statements beside the faces; `fo`, the old `f`.
  EXPECT_EQ(trianglesOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nvp 0.5\nl 1 2\np 3\ncstype bspline\ndeg 3\n"
                        "mg 1\nlod 1\nbevel off\nc_interp off\nd_interp off\nfo 1 2 3\n"),
            1u);
  // Leading blanks, exponents and signs on numbers, no newline at the end.
  EXPECT_EQ(trianglesOf("   v +0 -0 0e0\n  v 1E0 .0 0.\nv 0 1 0\n f 1 2 3"), 1u);
}

TEST_F(BadInputMesh, TheCheckKeepsLineNumbersAndTheVertexCounts) {
  const ObjCheck check = checkObjText("\xEF\xBB\xBFv 0 0 0\nv 1 0 \\\n0\nv 0 1 0\nfo 1 2 3\n");
  ASSERT_TRUE(check.ok()) << check.problem;
  EXPECT_EQ(check.vertices, 3u);
  EXPECT_EQ(check.faces, 1u);
  EXPECT_EQ(check.text, "v 0 0 0\nv 1 0  0\n\nv 0 1 0\nf 1 2 3\n") << "one line out per line in, BOM gone, fo -> f";
  EXPECT_EQ(checkObjText("v 0 0 0\n\n\nbad\n").problem, "line 4: 'bad' is not an OBJ statement");
}

TEST_F(BadInputMesh, TheCheckInPlaceGivesTheCopyingChecksTextAndProblems) {
  // checkObjTextInPlace writes the text over the bytes it has read (the scene loader's way, so a
  // big file is not held twice): it must give the very text and problems of checkObjText, with a
  // byte-order mark, continued lines, fo, comments, blanks, CR and CRLF line ends, and a last line
  // without a line break (whose break is the one character the text has beyond the bytes).
  const std::vector<std::string> texts = {
      "\xEF\xBB\xBFv 0 0 0\nv 1 0 \\\n0\nv 0 1 0\nfo 1 2 3\n",
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3",
      "# a comment\r\n   v 0 0 0   \r\n\tv 1 0 0\rv 0 1 0\r\n\r\nfo   1 2 \\\n 3 \\",
      "v 0 0 0\nv 1 0 0\nv 0 1 0\ng part\nusemtl x\nf 1 2 3\nf -3 -2 -1\n# end",
      "f",
      "v 0 0 0\nbad\n",
      "\xEF\xBB\xBF",
      std::string(40, 'v'),
  };
  for (const std::string& text : texts) {
    const ObjCheck copied = checkObjText(text), inPlace = checkObjTextInPlace(text);
    EXPECT_EQ(inPlace.problem, copied.problem) << text;
    EXPECT_EQ(inPlace.text, copied.text) << text;
    EXPECT_EQ(inPlace.vertices, copied.vertices) << text;
    EXPECT_EQ(inPlace.faces, copied.faces) << text;
  }
}

TEST_F(BadInputMesh, AFarmCoordinatorRefusesABadMeshAssetNamingIt) {
  // `lensfarm submit` checks the scene first, but the coordinator must refuse it on its own too:
  // InputError, which the service returns as INVALID_ARGUMENT.
  Coordinator coordinator;
  const std::string glb = std::string("glTF\x02\0\0\0", 8) + "{\"asset\":{}}";
  const std::string sha = sha256Hex(glb);
  coordinator.putAsset(sha, glb);
  JobSpec spec;
  spec.sceneName = "farm-scene.json";
  spec.sceneJson = sceneWith("meshes/chair.obj").dump();
  spec.assets["meshes/chair.obj"] = sha;
  try {
    coordinator.submit(spec, 0);
    FAIL() << "a glTF given as obj must be refused";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("farm-scene.json: shapes[1].file: \"meshes/chair.obj\": ", 0), 0u) << message;
    EXPECT_NE(message.find("glTF"), std::string::npos) << message;
  }
  EXPECT_TRUE(coordinator.jobs().empty());
}

}  // namespace
}  // namespace lensfarm
