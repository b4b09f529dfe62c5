// Numbers in OBJ files: a NaN, an infinity, a word or too few numbers in a
// vertex, normal or texture coordinate used to be read as 0 by tinyobjloader, with no message.
// Each is refused through the scene loader with one error naming the scene, the mesh entry, the
// OBJ file and the line. Coordinates are read in double: anything finite up to 1e30 in magnitude
// passes the OBJ check (the loader then bounds the distance from the camera).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/scene/obj_check.h"
#include "common/scene/scene_loader.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;
using test::kNoError;

class ObjNumbers : public test::SceneErrorTest {
 protected:
  ObjNumbers() : SceneErrorTest("scene.json") {}

  // The minimal scene plus shapes[1], an OBJ shape reading mesh.obj holding `text`: the message.
  std::string errorOfMesh(const std::string& text) const {
    dir_.write("mesh.obj", text);
    json j = test::minimalSceneJson();
    j["shapes"].push_back({{"type", "obj"}, {"file", "mesh.obj"}, {"material", "white"}});
    return errorOf(j);
  }
};

TEST_F(ObjNumbers, EveryBadNumberIsRefusedWithTheFileAndTheLine) {
  struct Case {
    std::string line;    // put on line 2 of a valid triangle
    std::string reason;  // what the message says after "line 2: "
  };
  const std::vector<Case> cases = {
      {"v nan 0 0", "'nan' is not a finite number"},
      {"v 0 NaN 0", "'NaN' is not a finite number"},
      {"v inf 0 0", "'inf' is not a finite number"},
      {"v 0 0 -infinity", "'-infinity' is not a finite number"},
      {"v 1e999 0 0", "'1e999' is not a finite number"},
      {"v 1e39 0 0", "coordinate '1e39' is beyond 1e30"},
      {"v 0 -1.000001e30 0", "coordinate '-1.000001e30' is beyond 1e30"},
      {"v abc 0 0", "'abc' is not a finite number"},
      {"v 0x10 0 0", "'0x10' is not a finite number"},
      {"v 1 2", "a vertex is 'v x y z'"},
      {"v 1 2 3 nan", "'nan' is not a finite number"},  // w
      {"vn nan 0 0", "'nan' is not a finite number"},
      {"vn 0 0 inf", "'inf' is not a finite number"},
      {"vn 0 1", "a normal is 'vn i j k', got 2 numbers"},
      {"vn", "a normal is 'vn i j k', got 0 numbers"},
      {"vn 0 0 one", "'one' is not a finite number"},
      {"vt inf 0", "'inf' is not a finite number"},
      {"vt 0.5 nan", "'nan' is not a finite number"},
      {"vt", "a texture coordinate is 'vt u [v [w]]', got 0 numbers"},
      {"vt 0 0 0 0", "a texture coordinate is 'vt u [v [w]]', got 4 numbers"},
      {"vp nan", "'nan' is not a finite number"},
  };
  const std::string prefix = sceneFile().string() + ": shapes[1].file: \"" + (dir_ / "mesh.obj").string() + "\": ";
  for (const Case& c : cases) {
    // The bad line is line 2, among good ones, so the line number is checked too.
    const std::string text = "v 0 0 0\n" + c.line + "\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 4\n";
    const std::string message = errorOfMesh(text);
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << c.line << ": " << message;
    EXPECT_NE(message.find("line 2: " + c.reason), std::string::npos) << c.line << ": " << message;
    // One error: the message is one line.
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST_F(ObjNumbers, FiniteNumbersUpTo1e30AndEveryUsualFormStillLoad) {
  for (const std::string line :
       {"v 1e30 0 0", "v -1e30 0 0", "v 1e-300 0 0", "v 5e-324 0 0", "v +1.5 -2 .5", "vn 0 0 1", "vn 1e300 0 0", "vt 0",
        "vt 0.5 0.5", "vt 0.5 0.5 0", "vp 0.5 0.5 1", "v 0 0 0 1", "v 0 0 0 0.5 0.5 0.5"}) {
    const ObjCheck check = checkObjText("v 0 0 0\n" + line + "\nv 1 0 0\nv 0 1 0\nf -1 -2 -3\n");
    EXPECT_TRUE(check.ok()) << line << ": " << check.problem;
  }
  // Through the loader: a triangle whose coordinates are plain numbers loads.
  EXPECT_EQ(errorOfMesh("v 0 0 0\nvn 0 0 1\nvt 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), kNoError);
}

}  // namespace
}  // namespace lensfarm
