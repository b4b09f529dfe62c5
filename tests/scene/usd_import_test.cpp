// USD (scene/usda_parser.h, usd_stage.h, usd_import.h) from files the tests write from the USD
// specification (openusd.org's schema docs): one test per prim type and arc, the numbers they
// must give worked out by hand, and bad files refused naming the file and the prim.
#include <gtest/gtest.h>
#include <zip.h>

#include <cmath>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <map>

#include "common/scene/scene_loader.h"
#include "common/scene/usd_import.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

const ModelFileReader kNoFiles = [](const std::string&) -> std::optional<std::string> { return std::nullopt; };

ModelFileReader filesOf(std::map<std::string, std::string> files) {
  return [files](const std::string& path) -> std::optional<std::string> {
    const auto it = files.find(path);
    if (it == files.end()) return std::nullopt;
    return it->second;
  };
}

ImportedModel usd(const std::string& body, const ModelFileReader& read = kNoFiles, const std::string& layer = "") {
  return importUsd("#usda 1.0\n" + layer + "\n" + body, "scene.usda", read);
}

std::string errorOf(const std::string& text, const ModelFileReader& read = kNoFiles) {
  try {
    (void)importUsd(text, "scene.usda", read);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// A unit quad in the XY plane at z = 0, counter-clockwise seen from +z, with `extra` lines.
std::string quadMesh(const std::string& name, const std::string& extra = "") {
  return "def Mesh \"" + name +
         "\" {\n"
         "  int[] faceVertexCounts = [4]\n"
         "  int[] faceVertexIndices = [0, 1, 2, 3]\n"
         "  point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]\n"
         "  uniform token subdivisionScheme = \"none\"\n" +
         extra + "}\n";
}

Vec3 normalOf(const MeshInput& m, size_t tri) {
  const uint32_t* i = &m.mesh.indices[3 * tri];
  const DVec3 n = glm::cross(m.positions[i[1]] - m.positions[i[0]], m.positions[i[2]] - m.positions[i[0]]);
  return Vec3(glm::normalize(n));
}

void expectNear(const DVec3& a, const DVec3& b, double tol = 1e-9) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

TEST(Usd, AQuadIsTwoTrianglesFacingItsCounterClockwiseSide) {
  const ImportedModel m = usd(quadMesh("Q"));
  ASSERT_EQ(m.meshes.size(), 1u);
  EXPECT_EQ(m.meshes[0].mesh.triangleCount(), 2u);
  EXPECT_NEAR(normalOf(m.meshes[0], 0).z, 1.0f, 1e-6f);
  EXPECT_NEAR(normalOf(m.meshes[0], 1).z, 1.0f, 1e-6f);
  // leftHanded flips the winding (UsdGeomGprim orientation).
  const ImportedModel l = usd(quadMesh("Q", "  uniform token orientation = \"leftHanded\"\n"));
  EXPECT_NEAR(normalOf(l.meshes[0], 0).z, -1.0f, 1e-6f);
}

TEST(Usd, FaceVaryingNormalsAndIndexedTexCoordsReachEveryCorner) {
  const ImportedModel m =
      usd(quadMesh("Q",
                   "  normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0.6, 0.8), (0, 0, 1)] (\n"
                   "    interpolation = \"faceVarying\"\n  )\n"
                   "  texCoord2f[] primvars:st = [(0, 0), (1, 0.25)] ( interpolation = \"faceVarying\" )\n"
                   "  int[] primvars:st:indices = [0, 1, 1, 0]\n"));
  const MeshInput& q = m.meshes[0];
  ASSERT_EQ(q.mesh.normals.size(), 4u);
  EXPECT_NEAR(q.mesh.normals[2].y, 0.6f, 1e-6f);
  ASSERT_EQ(q.mesh.uv[0].size(), 4u);
  // USD's t grows upwards, lensfarm's v downwards: v = 1 - t.
  EXPECT_FLOAT_EQ(q.mesh.uv[0][1].x, 1.0f);
  EXPECT_FLOAT_EQ(q.mesh.uv[0][1].y, 0.75f);
  EXPECT_FLOAT_EQ(q.mesh.uv[0][3].y, 1.0f);
}

TEST(Usd, XformOpsComposeInOrderWithInvertAndReset) {
  // translate, then rotateXYZ (about X first), then scale: M = T R S, the first op outermost.
  const ImportedModel m =
      usd("def Xform \"A\" {\n"
          "  double3 xformOp:translate = (10, 0, 0)\n"
          "  float3 xformOp:rotateXYZ = (0, 0, 90)\n"
          "  float3 xformOp:scale = (2, 2, 2)\n"
          "  uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateXYZ\", \"xformOp:scale\"]\n" +
          quadMesh("Q") +
          "  def Xform \"B\" {\n"
          "    double3 xformOp:translate = (0, 0, 5)\n"
          "    uniform token[] xformOpOrder = [\"!resetXformStack!\", \"xformOp:translate\", "
          "\"!invert!xformOp:translate\", "
          "\"xformOp:translate\"]\n" +
          quadMesh("R") + "  }\n}\n");
  ASSERT_EQ(m.meshes.size(), 2u);
  // The point (1, 0, 0) scaled to (2, 0, 0), turned 90 degrees about z to (0, 2, 0), moved to (10, 2, 0).
  expectNear(m.meshes[0].positions[1], DVec3(10, 2, 0), 1e-9);
  // B resets the stack: its own translate (the invert cancels one), nothing of A.
  expectNear(m.meshes[1].positions[1], DVec3(1, 0, 5));
}

TEST(Usd, OrientAndTransformOpsAreUsdsConventions) {
  // orient is written (w, x, y, z); transform acts on row vectors, its translation in the last row.
  const double h = std::sqrt(0.5);
  const ImportedModel m =
      usd("def Xform \"A\" {\n  quatf xformOp:orient = (" + std::to_string(h) + ", 0, 0, " + std::to_string(h) +
          ")\n  uniform token[] xformOpOrder = [\"xformOp:orient\"]\n" + quadMesh("Q") +
          "}\ndef Xform \"B\" {\n"
          "  matrix4d xformOp:transform = ((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (3, 4, 5, 1))\n"
          "  uniform token[] xformOpOrder = [\"xformOp:transform\"]\n" +
          quadMesh("Q") + "}\n");
  expectNear(m.meshes[0].positions[1], DVec3(0, 1, 0), 1e-6);  // 90 degrees about z
  expectNear(m.meshes[1].positions[1], DVec3(4, 4, 5));
}

TEST(Usd, AZUpStageIsTurnedToYUp) {
  const ImportedModel m = usd(quadMesh("Q"), kNoFiles, "( upAxis = \"Z\" )");
  // (x, y, z) -> (x, z, -y): the quad's (1, 1, 0) is (1, 0, -1), its normal +z is +y.
  expectNear(m.meshes[0].positions[2], DVec3(1, 0, -1), 1e-12);
  EXPECT_NEAR(normalOf(m.meshes[0], 0).y, 1.0f, 1e-6f);
}

TEST(Usd, GeomSubsetsBindTheirFacesToTheirOwnMaterials) {
  const std::string looks =
      "def Scope \"Looks\" {\n"
      "  def Material \"Red\" { token outputs:surface.connect = </Looks/Red/S.outputs:surface>\n"
      "    def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
      "      color3f inputs:diffuseColor = (0.8, 0, 0)\n      float inputs:roughness = 0.25 } }\n"
      "  def Material \"Blue\" { token outputs:surface.connect = </Looks/Blue/S.outputs:surface>\n"
      "    def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
      "      color3f inputs:diffuseColor = (0, 0, 0.7)\n      float inputs:metallic = 1 } } }\n";
  const ImportedModel m = usd(looks +
                              "def Mesh \"Two\" {\n"
                              "  int[] faceVertexCounts = [3, 3]\n  int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]\n"
                              "  point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]\n"
                              "  rel material:binding = </Looks/Red>\n"
                              "  def GeomSubset \"second\" { uniform token elementType = \"face\"\n"
                              "    uniform token familyName = \"materialBind\"\n    int[] indices = [1]\n"
                              "    rel material:binding = </Looks/Blue> }\n}\n");
  ASSERT_EQ(m.meshes.size(), 1u);
  const std::vector<uint32_t>& ids = m.meshes[0].mesh.materialIds;
  ASSERT_EQ(ids.size(), 2u);
  const MaterialTextures* red = m.materials[ids[0]].textures();
  const MaterialTextures* blue = m.materials[ids[1]].textures();
  ASSERT_TRUE(red && blue);
  EXPECT_FLOAT_EQ(red->factors.baseColor.x, 0.8f);
  EXPECT_FLOAT_EQ(red->factors.roughness, 0.25f);
  EXPECT_FLOAT_EQ(red->factors.metallic, 0.0f);  // UsdPreviewSurface's default, not glTF's
  EXPECT_FLOAT_EQ(blue->factors.baseColor.z, 0.7f);
  EXPECT_FLOAT_EQ(blue->factors.metallic, 1.0f);
  // The default subdivision scheme (catmullClark) is rendered as the control mesh, and said so.
  bool noted = false;
  for (const std::string& n : m.notes) noted |= n.find("subdivision (catmullClark)") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(Usd, UsdUvTextureIsReadRelativeToTheLayerThatNamesIt) {
  // A 1 x 1 PNG: the texture slot must be filled from the file the reader serves.
  const std::string png = test::readFile(test::scenesDir() / "models/checker.png");
  ASSERT_FALSE(png.empty());
  std::vector<std::string> asked;
  const ModelFileReader read = [&](const std::string& p) -> std::optional<std::string> {
    asked.push_back(p);
    return p == "tex/checker.png" ? std::optional<std::string>(png) : std::nullopt;
  };
  const ImportedModel m =
      usd("def Material \"M\" { token outputs:surface.connect = </M/S.outputs:surface>\n"
          "  def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
          "    color3f inputs:diffuseColor.connect = </M/T.outputs:rgb> }\n"
          "  def Shader \"T\" { uniform token info:id = \"UsdUVTexture\"\n    asset inputs:file = @tex/checker.png@\n"
          "    token inputs:wrapS = \"clamp\"\n    float3 outputs:rgb } }\n" +
              quadMesh("Q", "  rel material:binding = </M>\n"),
          read);
  ASSERT_EQ(m.materials.size(), 1u);
  ASSERT_TRUE(m.materials[0].textures());
  EXPECT_TRUE(bool(m.materials[0].textures()->baseColor));
  EXPECT_EQ(asked, std::vector<std::string>{"tex/checker.png"});
  EXPECT_NE(
      errorOf("#usda 1.0\ndef Material \"M\" { token outputs:surface.connect = </M/S.outputs:surface>\n"
              "def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
              "color3f inputs:diffuseColor.connect = </M/T.outputs:rgb> }\n"
              "def Shader \"T\" { uniform token info:id = \"UsdUVTexture\"\n asset inputs:file = @gone.png@ } }\n" +
              quadMesh("Q", "  rel material:binding = </M>\n")),
      "(no error)");
}

TEST(Usd, ACameraIsAPinholeOrAThinLensWithTheSameViewAtItsFocus) {
  const ImportedModel m = usd(
      "def Camera \"Pin\" { float focalLength = 35\n float horizontalAperture = 36\n float verticalAperture = 24 }\n"
      "def Camera \"Lens\" { float focalLength = 50\n float horizontalAperture = 36\n float verticalAperture = 24\n"
      "  float fStop = 2.8\n  float focusDistance = 300\n"
      "  double3 xformOp:translate = (0, 0, 10)\n  uniform token[] xformOpOrder = [\"xformOp:translate\"] }\n");
  ASSERT_EQ(m.cameras.size(), 2u);
  const auto& pin = m.cameras[0];
  EXPECT_EQ(pin["type"], "pinhole");
  EXPECT_NEAR(pin["angle_of_view"].get<double>(), 2 * std::atan(36.0 / 70.0) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(pin["aspect_ratio"].get<double>(), 1.5, 1e-12);
  const auto& lens = m.cameras[1];
  EXPECT_EQ(lens["type"], "thin_lens");
  // Tenths of a scene unit: f = 5; focused at 300, the sensor sits at S2 = f S1 / (S1 - f).
  const double f = 5.0, s2 = f * 300 / (300 - f);
  EXPECT_NEAR(lens["focal_length"].get<double>(), f, 1e-12);
  EXPECT_NEAR(lens["sensor_width"].get<double>(), 3.6 * s2 / f, 1e-12);
  EXPECT_NEAR(lens["f_number"].get<double>(), 2.8, 1e-6);
  EXPECT_NEAR(lens["focus_distance"].get<double>(), 300, 1e-12);
  // The view at the focal plane is the camera's: 2 atan(sensor / 2 S2) = 2 atan(36 / 2 focalLength).
  EXPECT_NEAR(std::atan(lens["sensor_width"].get<double>() / (2 * s2)), std::atan(36.0 / 100.0), 1e-12);
  EXPECT_EQ(lens["position"], nlohmann::json({0.0, 0.0, 10.0}));
  EXPECT_EQ(lens["look_at"], nlohmann::json({0.0, 0.0, 10.0 - 300.0}));  // along -z
}

TEST(Usd, LuxLightsCarryTheirRadianceIntoLensfarmsUnits) {
  const ImportedModel m =
      usd("def RectLight \"Rect\" { float inputs:width = 2\n float inputs:height = 0.5\n"
          "  float inputs:intensity = 3\n float inputs:exposure = 1\n color3f inputs:color = (1, 0.5, 0.25) }\n"
          "def RectLight \"Normalized\" { float inputs:width = 2\n float inputs:height = 2\n"
          "  float inputs:intensity = 8\n bool inputs:normalize = true }\n"
          "def SphereLight \"Bulb\" { float inputs:radius = 0.1\n float inputs:intensity = 100 }\n"
          "def SphereLight \"Spot\" ( prepend apiSchemas = [\"ShapingAPI\"] ) { float inputs:radius = 0\n"
          "  float inputs:intensity = 5\n float inputs:shaping:cone:angle = 30\n float inputs:shaping:cone:softness = "
          "0.5 }\n"
          "def DistantLight \"Sun\" { float inputs:angle = 1\n float inputs:intensity = 1000 }\n"
          "def DiskLight \"Disk\" { float inputs:radius = 0.5\n float inputs:intensity = 2 }\n"
          "def DomeLight \"Sky\" {}\n");
  ASSERT_EQ(m.lights.size(), 6u);
  // A disk of radius r as the square of its area: side r sqrt(pi), the same radiance.
  const auto& disk = m.lights[5];
  EXPECT_EQ(disk["type"], "quad");
  EXPECT_NEAR(disk["edge1"][1].get<double>(), 0.5 * std::sqrt(M_PI), 1e-12);
  EXPECT_NEAR(disk["radiance"][0].get<double>(), 2.0, 1e-12);
  bool domeNoted = false;
  for (const std::string& n : m.notes) domeNoted |= n.find("not rendered (DomeLight): </Sky>") != std::string::npos;
  EXPECT_TRUE(domeNoted);
  const auto& rect = m.lights[0];
  EXPECT_EQ(rect["type"], "quad");
  EXPECT_NEAR(rect["radiance"][0].get<double>(), 6.0, 1e-12);  // 3 x 2^1
  EXPECT_NEAR(rect["radiance"][2].get<double>(), 1.5, 1e-12);
  // Centred on the light, facing -z: edge1 x edge2 = (0, 0.5, 0) x (2, 0, 0) = (0, 0, -1).
  EXPECT_EQ(rect["corner"], nlohmann::json({-1.0, -0.25, 0.0}));
  EXPECT_NEAR(m.lights[1]["radiance"][0].get<double>(), 2.0, 1e-12);  // 8 / (2 x 2)
  EXPECT_EQ(m.lights[2]["type"], "point");
  EXPECT_NEAR(m.lights[2]["intensity"][0].get<double>(), 100 * M_PI * 0.01, 1e-9);  // L pi r^2
  EXPECT_EQ(m.lights[3]["type"], "spot");
  EXPECT_NEAR(m.lights[3]["cone_angle"].get<double>(), 30.0, 1e-12);
  EXPECT_NEAR(m.lights[3]["falloff_start"].get<double>(), 15.0, 1e-12);
  EXPECT_EQ(m.lights[4]["type"], "directional");
  const double s = std::sin(0.5 * M_PI / 180);
  EXPECT_NEAR(m.lights[4]["irradiance"][0].get<double>(), 1000 * M_PI * s * s, 1e-9);
  EXPECT_EQ(m.lights[4]["direction"], nlohmann::json({0.0, 0.0, 1.0}));  // towards the light: +z
}

TEST(Usd, ReferencesComposeAndInstancesShareOnePrototype) {
  const std::string box = "#usda 1.0\n( defaultPrim = \"Box\" )\ndef Xform \"Box\" {\n" +
                          quadMesh("Side", "  rel material:binding = </Box/M>\n") +
                          "  def Material \"M\" { token outputs:surface.connect = </Box/M/S.outputs:surface>\n"
                          "    def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
                          "      color3f inputs:diffuseColor = (0.1, 0.9, 0.1) } }\n}\n";
  const ImportedModel m =
      usd("def Xform \"A\" ( instanceable = true\n references = @props/box.usda@ ) {\n"
          "  double3 xformOp:translate = (5, 0, 0)\n  uniform token[] xformOpOrder = [\"xformOp:translate\"] }\n"
          "def Xform \"B\" ( instanceable = true\n references = @props/box.usda@</Box> ) {}\n"
          "def Xform \"C\" ( references = @props/box.usda@ ) {\n"
          "  over \"Side\" { point3f[] points = [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)] } }\n"
          "def Xform \"D\" ( references = </C> ) {}\n",
          filesOf({{"props/box.usda", box}}));
  // A and B: one prototype mesh, two instances; C composed as a copy with its override; D
  // references C (an internal reference) and gets C's overridden mesh.
  ASSERT_EQ(m.prototypes.size(), 1u);
  ASSERT_EQ(m.instances.size(), 2u);
  EXPECT_NEAR(m.instances[0].world[3].x, 5.0, 1e-12);
  ASSERT_EQ(m.meshes.size(), 2u);
  EXPECT_NEAR(m.meshes[0].positions[0].z, 1.0, 1e-12);
  EXPECT_NEAR(m.meshes[1].positions[0].z, 1.0, 1e-12);
  // The referenced material binding is mapped onto the referencing prim: the green material.
  for (const Material& mat : m.materials) EXPECT_FLOAT_EQ(mat.textures()->factors.baseColor.y, 0.9f);
}

TEST(Usd, BadFilesAreRefusedNamingTheFileLineAndPrim) {
  const std::string mesh = quadMesh("Q");
  const std::map<std::string, std::string> cases = {
      {"#usda 1.0\ndef Mesh \"Q\" {\n  int[] faceVertexCounts = [4", "scene.usda: line 3"},  // truncated
      {"#usda 1.0\ndef Bogus \"X\" {}\n", "</X>: unknown prim type \"Bogus\""},
      {"# not usd\n", "does not begin with \"#usda 1.0\""},
      {"PXR-USDC\x01\x02", "binary USD crate file (usdc)"},
      {std::string("PK\x03\x04", 4) + "rest", "is not a readable USDZ package (zip)"},
      {"#usda 1.0\ndef Mesh \"Q\" { int[] faceVertexCounts = [4]\n int[] faceVertexIndices = [0, 1, 2]\n"
       " point3f[] points = [(0,0,0),(1,0,0),(1,1,0)] }\n",
       "</Q>: faceVertexCounts add up to 4 but faceVertexIndices has 3"},
      {"#usda 1.0\ndef Mesh \"Q\" { int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 9]\n"
       " point3f[] points = [(0,0,0),(1,0,0),(1,1,0)] }\n",
       "</Q>: faceVertexIndices[2] = 9 is not a point (3 points)"},
      {"#usda 1.0\ndef Mesh \"Q\" { int[] faceVertexCounts = [4000000000000]\n int[] faceVertexIndices = [0]\n"
       " point3f[] points = [(0,0,0)] }\n",
       "</Q>: faceVertexCounts[0] = 4e+12"},
      {"#usda 1.0\ndef Mesh \"Q\" { point3f[] points = [(0, 0)] }\n", "</Q>: points: expected an array of 3-tuples"},
      {"#usda 1.0\ndef Xform \"A\" ( references = </B> ) {}\ndef Xform \"B\" ( references = </A> ) {}\n",
       "references form a cycle"},
      {"#usda 1.0\ndef Xform \"A\" ( references = @missing.usda@ ) {}\n", "\"missing.usda\", which cannot be read"},
      {"#usda 1.0\ndef Xform \"A\" ( references = </Nowhere> ) {}\n", "</Nowhere>, which does not exist"},
      {"#usda 1.0\n( upAxis = \"X\" )\n", "upAxis: \"X\" is not \"Y\" or \"Z\""},
      {"#usda 1.0\ndef Xform \"A\" { uniform token[] xformOpOrder = [\"xformOp:translate\"] }\n",
       "</A>: xformOpOrder names xformOp:translate, which the prim does not have"},
      {"#usda 1.0\ndef Camera \"C\" { float focalLength = -1 }\n", "</C>: focalLength, horizontalAperture"},
      {"#usda 1.0\n" + mesh.substr(0, mesh.size() - 2) + " rel material:binding = </Nope> }\n",
       "</Q>: material:binding names </Nope>, which does not exist"},
  };
  for (const auto& [text, says] : cases) {
    const std::string e = errorOf(text);
    EXPECT_NE(e.find("scene.usda"), std::string::npos) << e;
    EXPECT_NE(e.find(says), std::string::npos) << "expected \"" << says << "\" in: " << e;
  }
  // Nesting beyond the limit is refused, not a stack overflow.
  std::string deep = "#usda 1.0\ndef Xform \"A\" { float[] x = ";
  for (int i = 0; i < 100000; ++i) deep += "[";
  EXPECT_NE(errorOf(deep).find("nested more than"), std::string::npos);
  // A reference cycle through another file names the chain.
  const std::string a = "#usda 1.0\ndef Xform \"A\" ( references = @b.usda@</B> ) {}\n";
  const std::string b = "#usda 1.0\ndef Xform \"B\" ( references = @a.usda@</A> ) {}\n";
  const std::string e = errorOf(a, filesOf({{"a.usda", a}, {"b.usda", b}}));
  EXPECT_NE(e.find("references form a cycle: b.usda</B> -> a.usda</A> -> b.usda</B>"), std::string::npos) << e;
}

TEST(Usd, AReferenceChainThatWouldExplodeIsStoppedAtTheComposedPrimLimit) {
  // Each level references the one below twice: 2^30 prims if composed naively.
  std::string text = "#usda 1.0\ndef Xform \"L0\" {}\n";
  for (int i = 1; i <= 30; ++i)
    text += "def Xform \"L" + std::to_string(i) + "\" {\n  def \"a\" ( references = </L" + std::to_string(i - 1) +
            "> ) {}\n  def \"b\" ( references = </L" + std::to_string(i - 1) + "> ) {}\n}\n";
  EXPECT_NE(errorOf(text).find("prims once its references are composed"), std::string::npos);
}

TEST(Usd, AUsdaFileIsAModelScene) {
  test::TempDir dir;
  const std::filesystem::path file =
      dir.write("tri.usda", "#usda 1.0\n" + quadMesh("Q") +
                                "def Camera \"Cam\" { double3 xformOp:translate = (0.5, 0.5, 3)\n"
                                "  uniform token[] xformOpOrder = [\"xformOp:translate\"] }\n"
                                "def RectLight \"L\" { double3 xformOp:translate = (0.5, 0.5, 2)\n"
                                "  uniform token[] xformOpOrder = [\"xformOp:translate\"] }\n");
  EXPECT_TRUE(isModelFile(file));
  EXPECT_EQ(modelShapeTypeOf("x.USDZ"), "usd");
  const Scene scene = loadScene(file);
  ASSERT_FALSE(scene.meshes.empty());
  EXPECT_GT(scene.meshes[0].triangleCount(), 0u);
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// The same two quads (a grey floor and a red wall, as UsdPreviewSurface and as glTF's
// metallic-roughness) read from USD and from glTF render the same image, bit for bit: both
// importers give the same triangles in the same order and the same principled materials.
TEST(Usd, TheSameSceneAsGltfRendersTheSameImage) {
  test::TempDir dir;
  const std::vector<float> points = {-2, 0, -2, -2, 0, 2,  2, 0,    2,  2,  0,    -2,   // floor, facing +y
                                     -1, 0, -1, 1,  0, -1, 1, 1.5f, -1, -1, 1.5f, -1};  // wall, facing +z
  const std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3};           // each mesh its own 4 points
  std::string bin(reinterpret_cast<const char*>(points.data()), points.size() * sizeof(float));
  bin.append(reinterpret_cast<const char*>(indices.data()), indices.size() * sizeof(uint32_t));
  dir.write("m.bin", bin);
  const nlohmann::json gltf = {
      {"asset", {{"version", "2.0"}}},
      {"buffers", {{{"uri", "m.bin"}, {"byteLength", bin.size()}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 24 * 4}},
        {{"buffer", 0}, {"byteOffset", 24 * 4}, {"byteLength", 12 * 4}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"byteOffset", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {-2, 0, -2}},
         {"max", {2, 0, 2}}},
        {{"bufferView", 0},
         {"byteOffset", 48},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {-1, 0, -1}},
         {"max", {1, 1.5, -1}}},
        {{"bufferView", 1}, {"byteOffset", 0}, {"componentType", 5125}, {"count", 6}, {"type", "SCALAR"}},
        {{"bufferView", 1}, {"byteOffset", 24}, {"componentType", 5125}, {"count", 6}, {"type", "SCALAR"}}}},
      {"materials",
       {{{"name", "grey"},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {0.6, 0.6, 0.6, 1}}, {"metallicFactor", 0}, {"roughnessFactor", 0.7}}}},
        {{"name", "red"},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {0.8, 0.1, 0.1, 1}}, {"metallicFactor", 0}, {"roughnessFactor", 0.4}}}}}},
      {"meshes",
       {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 2}, {"material", 0}}}}},
        {{"primitives", {{{"attributes", {{"POSITION", 1}}}, {"indices", 3}, {"material", 1}}}}}}},
      {"nodes", {{{"mesh", 0}}, {{"mesh", 1}}}},
      {"scenes", {{{"nodes", {0, 1}}}}},
      {"scene", 0}};
  dir.write("m.gltf", gltf.dump());
  const auto surface = [](const std::string& name, const std::string& colour, double roughness) {
    return "def Material \"" + name + "\" { token outputs:surface.connect = </Looks/" + name +
           "/S.outputs:surface>\n  def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
           "  color3f inputs:diffuseColor = " +
           colour + "\n  float inputs:roughness = " + std::to_string(roughness) + " } }\n";
  };
  const auto quad = [](const std::string& name, const std::string& pts, const std::string& material) {
    return "def Mesh \"" + name +
           "\" {\n int[] faceVertexCounts = [4]\n int[] faceVertexIndices = [0, 1, 2, 3]\n point3f[] points = " + pts +
           "\n uniform token subdivisionScheme = \"none\"\n rel material:binding = </Looks/" + material + ">\n}\n";
  };
  dir.write("m.usda", "#usda 1.0\ndef Scope \"Looks\" {\n" + surface("grey", "(0.6, 0.6, 0.6)", 0.7) +
                          surface("red", "(0.8, 0.1, 0.1)", 0.4) + "}\n" +
                          quad("Floor", "[(-2, 0, -2), (-2, 0, 2), (2, 0, 2), (2, 0, -2)]", "grey") +
                          quad("Wall", "[(-1, 0, -1), (1, 0, -1), (1, 1.5, -1), (-1, 1.5, -1)]", "red"));
  const auto scene = [](const std::string& type, const std::string& file) {
    return nlohmann::json{
        {"format", "lensfarm-scene/1"},
        {"render", {{"resolution", {24, 16}}, {"samples_per_pixel", 16}, {"max_bounces", 3}}},
        {"camera", {{"type", "pinhole"}, {"position", {0, 1, 4}}, {"look_at", {0, 0.5, 0}}, {"angle_of_view", 60}}},
        {"lights",
         {{{"type", "quad"},
           {"corner", {-0.5, 3, -0.5}},
           {"edge1", {1, 0, 0}},
           {"edge2", {0, 0, 1}},
           {"radiance", 8}}}},
        {"shapes", {{{"type", type}, {"file", file}}}}};
  };
  const Scene fromUsd = test::loadSceneJson(dir, scene("usd", "m.usda"), "usd.json");
  const Scene fromGltf = test::loadSceneJson(dir, scene("gltf", "m.gltf"), "gltf.json");
  const test::Rendered a = test::renderScene(fromUsd), b = test::renderScene(fromGltf);
  EXPECT_GT(a.mean[0], 0.0);
  EXPECT_TRUE(a.image.rgb == b.image.rgb) << "USD " << a.mean[0] << " glTF " << b.mean[0];
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// A .usdz written with libzip as USD's tools write one (entries stored), from {name: bytes}.
std::string usdzOf(const test::TempDir& dir, const std::vector<std::pair<std::string, std::string>>& entries) {
  const std::filesystem::path file = dir / "package.usdz";
  int error = 0;
  zip_t* z = zip_open(file.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &error);
  EXPECT_NE(z, nullptr);
  for (const auto& [name, bytes] : entries) {
    zip_source_t* s = zip_source_buffer(z, bytes.data(), bytes.size(), 0);
    const zip_int64_t i = zip_file_add(z, name.c_str(), s, ZIP_FL_ENC_UTF_8);
    EXPECT_GE(i, 0);
    zip_set_file_compression(z, zip_uint64_t(i), ZIP_CM_STORE, 0);
  }
  EXPECT_EQ(zip_close(z), 0);
  return test::readFile(file);
}

TEST(Usd, AUsdzPackageIsReadWithTheFilesItHolds) {
  test::TempDir dir;
  const std::string png = test::readFile(test::scenesDir() / "models/checker.png");
  const std::string root =
      "#usda 1.0\n( defaultPrim = \"W\" )\ndef Xform \"W\" ( references = @parts/quad.usda@ ) {}\n"
      "def Material \"M\" { token outputs:surface.connect = </M/S.outputs:surface>\n"
      "  def Shader \"S\" { uniform token info:id = \"UsdPreviewSurface\"\n"
      "    color3f inputs:diffuseColor.connect = </M/T.outputs:rgb> }\n"
      "  def Shader \"T\" { uniform token info:id = \"UsdUVTexture\"\n    asset inputs:file = @tex/c.png@ } }\n";
  const std::string part = "#usda 1.0\n( defaultPrim = \"P\" )\ndef Xform \"P\" {\n" +
                           quadMesh("Q", "  rel material:binding = </M>\n") + "}\n";
  const std::string package = usdzOf(dir, {{"scene.usda", root}, {"parts/quad.usda", part}, {"tex/c.png", png}});
  std::vector<std::string> askedOutside;
  const ModelFileReader outside = [&](const std::string& p) -> std::optional<std::string> {
    askedOutside.push_back(p);
    return std::nullopt;
  };
  const ImportedModel m = importUsd(package, "scene.usdz", outside);
  ASSERT_EQ(m.meshes.size(), 1u);
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_TRUE(bool(m.materials[0].textures()->baseColor)) << "the texture came from inside the package";
  EXPECT_TRUE(askedOutside.empty()) << "nothing is read beside the package";
  // A package whose root layer is binary, one with no layer, and bytes that are not a zip.
  const std::string crate = usdzOf(dir, {{"scene.usdc", "PXR-USDC\x01"}});
  EXPECT_NE(errorOf(crate).find("scene.usdc: is a binary USD crate file (usdc)"), std::string::npos) << errorOf(crate);
  EXPECT_NE(errorOf(usdzOf(dir, {{"readme.txt", "no layer"}})).find("holds no USD layer"), std::string::npos);
  const std::string broken = std::string("PK\x03\x04", 4) + std::string(40, '\x7f');
  EXPECT_NE(errorOf(broken).find("is not a readable USDZ package"), std::string::npos) << errorOf(broken);
}

}  // namespace
}  // namespace lensfarm
