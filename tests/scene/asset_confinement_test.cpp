// Files a scene names stay inside its folder (scene/asset_path.h): a `..` that climbs out, an
// absolute path, a symlink whose target lies outside and a URL are each refused with one
// sentence naming the file and field, for every kind of reference (a scene's mesh, a glTF
// buffer or image, an OBJ's mtllib) and on every path in (loading, the coordinator's asset
// names); a folder the user allows is read.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "common/scene/asset_path.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "tests/scene/asset_confinement_support.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::kTriangleObj;
using test::Layout;

std::string loadError(const fs::path& scene, const std::vector<fs::path>& allowed = {}) {
  try {
    std::string text;
    if (isModelFile(scene))
      (void)modelScene(scene, text, fileAssetReader(scene, allowed));
    else
      (void)parseScene(test::readFile(scene), scene, fileAssetReader(scene, allowed));
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(AssetConfinement, AScenesFilesMustLieInsideItsFolder) {
  const Layout l;
  EXPECT_EQ(loadError(l.sceneWithMesh("models/../models/../inside.obj")),
            (l.root / "scene.json").string() + ": shapes[0].file: cannot read OBJ file \"" +
                (l.root / "models/../models/../inside.obj").string() + "\": no such file (looked for " +
                (l.root / "inside.obj").string() + ")");
  l.write("inside.obj", kTriangleObj);
  EXPECT_EQ(loadError(l.sceneWithMesh("models/../inside.obj")), "<no error>");

  const std::string climbs = loadError(l.sceneWithMesh("../secret.obj"));
  EXPECT_TRUE(test::contains(climbs, "shapes[0].file: \"../secret.obj\" lies outside " + l.root.string()));
  EXPECT_TRUE(test::contains(climbs, "--allow-path"));
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("models/../../secret.obj")), "lies outside"));
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh(l.secret.string())),
                             "shapes[0].file: \"" + l.secret.string() + "\" is an absolute path outside"));
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("https://example.com/x.obj")),
                             "shapes[0].file: \"https://example.com/x.obj\" is a URL (https:)"));
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("file:///etc/passwd")), "is a URL (file:)"));
}

TEST(AssetConfinement, ASymlinkOutOfTheFolderIsRefusedAndOneInsideIsRead) {
  const Layout l;
  fs::create_symlink(l.secret, l.root / "link.obj");
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("link.obj")),
                             "shapes[0].file: \"link.obj\" is a symlink to " + l.secret.string() + ", outside"));
  // A folder symlinked out: the same.
  fs::create_directory_symlink(l.dir.path(), l.root / "up");
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("up/secret.obj")), "is a symlink to"));
  // Inside the folder a symlink is a file like any other.
  l.write("models/real.obj", kTriangleObj);
  fs::create_symlink(l.root / "models/real.obj", l.root / "alias.obj");
  EXPECT_EQ(loadError(l.sceneWithMesh("alias.obj")), "<no error>");
}

TEST(AssetConfinement, AnAllowedFolderIsRead) {
  const Layout l;
  const fs::path scene = l.sceneWithMesh("../secret.obj");
  EXPECT_EQ(loadError(scene, {l.dir.path()}), "<no error>");
  // By an absolute path too (a shared asset library), and allowed through the environment.
  EXPECT_EQ(loadError(l.sceneWithMesh(l.secret.string()), {l.dir.path()}), "<no error>");
  const char* before = std::getenv("LENSFARM_ALLOW_PATH");
  const std::string saved = before ? before : "";
  setenv("LENSFARM_ALLOW_PATH", ("/nonexistent:" + l.dir.path().string()).c_str(), 1);
  EXPECT_EQ(loadError(l.sceneWithMesh(l.secret.string())), "<no error>");
  if (before)
    setenv("LENSFARM_ALLOW_PATH", saved.c_str(), 1);
  else
    unsetenv("LENSFARM_ALLOW_PATH");
  fs::create_symlink(l.secret, l.root / "link.obj");
  EXPECT_EQ(loadError(l.sceneWithMesh("link.obj"), {l.dir.path()}), "<no error>");
  // Allowing one folder allows nothing beside it.
  fs::create_directories(l.dir / "other");
  EXPECT_TRUE(test::contains(loadError(l.sceneWithMesh("../secret.obj"), {l.dir / "other"}), "lies outside"));
}

TEST(AssetConfinement, AGltfModelReadsOnlyItsOwnFolder) {
  // A downloaded model whose buffer names a file elsewhere, with the right byteLength: refused
  // before a byte is read, naming the model; a remote buffer gets one sentence.
  const Layout l;
  test::Builder b;
  b.doc["meshes"] = json::array();
  const auto model = [&](const std::string& uri) {
    json d = json::parse(b.gltf(uri));
    d["buffers"][0]["byteLength"] = 36;
    return l.write("models/model.gltf", d.dump());
  };
  for (const std::string uri : {"../../secret.bin", "..%2F..%2Fsecret.bin"}) {
    const std::string e = loadError(model(uri));
    EXPECT_TRUE(test::contains(e, "model.gltf")) << uri;
    EXPECT_TRUE(test::contains(e, "lies outside")) << uri;
  }
  const std::string remote = loadError(model("https://example.com/buffer.bin"));
  EXPECT_TRUE(test::contains(remote, "buffers[0].uri: \"https://example.com/buffer.bin\" is a URL (https:)"));
  EXPECT_TRUE(test::contains(loadError(model("/etc/passwd")), "\"/etc/passwd\" is an absolute path outside"));
  // An image too (beside a buffer of data, which is read).
  b.floats({0.0f, 0.0f, 0.0f}, "VEC3");
  json d = json::parse(b.embedded());
  d["images"] = {{{"uri", "../../secret.png"}}};
  EXPECT_TRUE(test::contains(loadError(l.write("models/textured.gltf", d.dump())), "lies outside"));
}

TEST(AssetConfinement, AnObjsMaterialLibraryStaysInside) {
  const Layout l;
  l.dir.write("secret.mtl", "newmtl red\nKd 1 0 0\n");
  l.write("models/m.obj", "mtllib ../../secret.mtl\n" + kTriangleObj);
  json j = test::minimalSceneJson();
  j["shapes"] = {{{"type", "obj"}, {"file", "models/m.obj"}, {"material", "white"}}};
  const std::string e = loadError(l.write("scene.json", j.dump()));
  EXPECT_TRUE(test::contains(e, "\"../../secret.mtl\" lies outside")) << e;
}

TEST(AssetConfinement, TheCoordinatorRefusesAssetNamesThatAreURLs) {
  // Asset names are keys of the job's uploaded files: never a URL. (An absolute name is a key like
  // any other, allowed where the client allowed its folder; the coordinator reads no file by it.)
  Coordinator c;
  for (const std::string name : {"https://example.com/x.obj", "file:///etc/passwd", ""}) {
    JobSpec spec;
    spec.sceneName = "scene.json";
    spec.sceneJson = test::minimalSceneJson().dump();
    spec.assets[name] = sha256Hex("x");
    try {
      c.submit(spec, 0);
      ADD_FAILURE() << name << " accepted";
    } catch (const FarmError& e) {
      EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument) << name;
      EXPECT_TRUE(test::contains(e.what(), "assets[\"" + name + "\"]")) << e.what();
    }
  }
}

TEST(AssetConfinement, PathProblemsAreRecognisedByForm) {
  // By their form alone: URLs and paths that name nothing.
  for (const std::string& bad :
       std::vector<std::string>{"http://a/b.obj", "S3://bucket/b.obj", "file:///x", "", std::string("a\0b", 3)})
    EXPECT_TRUE(unreadablePathProblem(bad)) << bad;
  for (const std::string path : {"meshes/a.obj", "../a.obj", "/a.obj", "C:/a.obj", "a:b.obj"})
    EXPECT_FALSE(unreadablePathProblem(path)) << path;
  // Where they lead, by the reader: out of the root, absolute or on another drive, refused.
  const test::TempDir dir;
  for (const std::string out : {"../a.obj", "/etc/passwd", "C:/a.obj", "C:\\a.obj"})
    EXPECT_THROW((void)confinedFile(dir.path(), out, {}), AssetRefused) << out;
  EXPECT_EQ(confinedFile(dir.path(), "a/../b.obj", {}), dir.path() / "b.obj");
}

}  // namespace
}  // namespace lensfarm
