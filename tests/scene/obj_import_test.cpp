// scene/obj_import.h: OBJ geometry (positions, normals, texture coordinates, groups, usemtl) and
// MTL materials with their textures, read through a ModelFileReader, and bad files refused with
// one InputError naming the file.
#include "common/scene/obj_import.h"

#include <gtest/gtest.h>
// The double build, as lensfarm_common links it (the test binary does not get its definition).
#ifndef TINYOBJLOADER_USE_DOUBLE
#define TINYOBJLOADER_USE_DOUBLE
#endif
#include <tiny_obj_loader.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "common/scene/obj_check.h"
#include "common/texture/image_decode.h"
#include "common/util/error.h"
#include "tests/test_support.h"
#include "tests/texture/test_images.h"

namespace lensfarm {
namespace {

static_assert(std::is_same_v<tinyobj::real_t, double>);

// Files by path relative to the OBJ file; records what was asked for.
struct Files {
  std::map<std::string, std::string> files;
  mutable std::vector<std::string> asked;
  ModelFileReader reader() const {
    return [this](const std::string& path) -> std::optional<std::string> {
      asked.push_back(path);
      const auto it = files.find(path);
      if (it == files.end()) return std::nullopt;
      return it->second;
    };
  }
};

ImportedObj import(const std::string& obj, const Files& files = {}) {
  return importObj(obj, "models/model.obj", files.reader());
}

std::string errorOf(const std::string& obj, const Files& files = {}) {
  try {
    import(obj, files);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool hasNote(const ImportedModel& model, const std::string& part) {
  for (const std::string& note : model.notes)
    if (note.find(part) != std::string::npos) return true;
  return false;
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const char* kQuad =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "vn 0 0 1\n";

// ---- geometry ----

TEST(ObjImport, WithoutNormalsOrTexcoordsKeepsTheFilesNumbering) {
  // What the scene loader's OBJ reader has always produced: tinyobjloader's vertices in file order
  // and its triangulated indices, so existing scenes load bit-identically.
  const std::vector<std::string> objs = {
      readFile(test::scenesDir() / "meshes/cornell-box.obj"), readFile(test::scenesDir() / "meshes/sphere.obj"),
      readFile(test::scenesDir() / "meshes/cube.obj"),
      "v 0 0 0\nv 9 9 9\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng a\nf 1 3 4 5\ng b\nf -5 -3 -2\nf 1 3 4 5 4\n",
      test::sphereObj(7, 9)};
  for (const std::string& text : objs) {
    const ObjCheck check = checkObjText(text);
    ASSERT_TRUE(check.ok()) << check.problem;
    tinyobj::ObjReaderConfig config;
    config.triangulate = true;
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    ASSERT_TRUE(reader.ParseFromString(check.text, "", config));
    std::vector<DVec3> positions;
    const auto& v = reader.GetAttrib().vertices;
    for (size_t k = 0; k < v.size(); k += 3) positions.emplace_back(v[k], v[k + 1], v[k + 2]);
    std::vector<uint32_t> indices;
    for (const auto& shape : reader.GetShapes())
      for (const auto& index : shape.mesh.indices) indices.push_back(uint32_t(index.vertex_index));

    const ImportedObj obj = import(text);
    ASSERT_EQ(obj.model.meshes.size(), 1u);
    const MeshInput& mesh = obj.model.meshes[0];
    EXPECT_EQ(mesh.positions, positions);
    EXPECT_EQ(mesh.mesh.indices, indices);
    EXPECT_TRUE(mesh.mesh.normals.empty());
    EXPECT_TRUE(mesh.mesh.uv[0].empty());
    EXPECT_EQ(mesh.mesh.materialIds, std::vector<uint32_t>(indices.size() / 3, kNoObjMaterial));
    EXPECT_EQ(obj.triangleGroups.size(), indices.size() / 3);
    EXPECT_TRUE(obj.model.materials.empty());
  }
}

TEST(ObjImport, NormalsAndTexcoordsAreReadWithVFlippedAndTriplesShared) {
  const ImportedObj obj = import(std::string(kQuad) + "vt 0.25 0.75\nvn 0 2 0\n" +
                                 "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n"  // a quad: 4 distinct triples
                                 "f 1/5/2 2/2/1 3/3/1\n");                     // vertex 1 again, other vt and vn
  const MeshInput& in = obj.model.meshes[0];
  const TriangleMesh& mesh = in.mesh;
  ASSERT_EQ(mesh.triangleCount(), 3u);
  EXPECT_EQ(in.positions.size(), 5u);  // (1,1,1) (2,2,1) (3,3,1) (4,4,1) (1,5,2)
  ASSERT_EQ(mesh.normals.size(), in.positions.size());
  ASSERT_EQ(mesh.uv[0].size(), in.positions.size());
  EXPECT_TRUE(mesh.uv[1].empty());
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 1, 2}));
  EXPECT_EQ(in.positions[4], DVec3(0, 0, 0));
  // v' = 1 - v: OBJ's v grows upwards, glTF's (and the textures' rows) downwards.
  EXPECT_EQ(mesh.uv[0][0], Vec2(0.0f, 1.0f));
  EXPECT_EQ(mesh.uv[0][2], Vec2(1.0f, 0.0f));
  EXPECT_EQ(mesh.uv[0][4], Vec2(0.25f, 0.25f));
  // Normals as written (the scene loader normalises them after the shape's transform).
  EXPECT_EQ(mesh.normals[0], Vec3(0, 0, 1));
  EXPECT_EQ(mesh.normals[4], Vec3(0, 2, 0));
  EXPECT_EQ(obj.model.lo, DVec3(0, 0, 0));
  EXPECT_EQ(obj.model.hi, DVec3(1, 1, 0));
  EXPECT_TRUE(obj.model.notes.empty());
}

TEST(ObjImport, FacesWithoutSomeAttributesGetDefaults) {
  // The second triangle has texture coordinates but no normals; the third neither.
  const ImportedObj obj = import(std::string(kQuad) + "v 0 0 5\n" + "f 1/1/1 2/2/1 3/3/1\nf 1/1 3/3 4/4\nf 2 5 3\n");
  const TriangleMesh& mesh = obj.model.meshes[0].mesh;
  ASSERT_EQ(mesh.triangleCount(), 3u);
  // Corners without vn take their triangle's normal (and are not shared with other triangles).
  const Vec3 n1 = glm::normalize(glm::cross(Vec3(1, 1, 0) - Vec3(0, 0, 0), Vec3(0, 1, 0) - Vec3(0, 0, 0)));
  for (size_t c = 3; c < 6; ++c) EXPECT_EQ(mesh.normals[mesh.indices[c]], n1);
  const Vec3 n2 = glm::normalize(glm::cross(Vec3(0, 0, 5) - Vec3(1, 0, 0), Vec3(1, 1, 0) - Vec3(1, 0, 0)));
  for (size_t c = 6; c < 9; ++c) {
    EXPECT_NEAR(glm::length(mesh.normals[mesh.indices[c]] - n2), 0.0f, 1e-6f);
    EXPECT_EQ(mesh.uv[0][mesh.indices[c]], Vec2(0.0f));  // no vt: (0, 0)
  }
  EXPECT_NE(mesh.indices[3], mesh.indices[0]);  // vertex 1 with vn and without: two vertices
  EXPECT_TRUE(hasNote(obj.model, "2 triangles have corners without a normal"));
  EXPECT_TRUE(hasNote(obj.model, "1 triangles have corners without texture coordinates"));
}

TEST(ObjImport, ZeroNormalsTakeTheTrianglesNormal) {
  const ImportedObj obj = import("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n");
  const TriangleMesh& mesh = obj.model.meshes[0].mesh;
  for (uint32_t i : mesh.indices) EXPECT_EQ(mesh.normals[i], Vec3(0, 0, 1));
  EXPECT_TRUE(hasNote(obj.model, "or with a zero one"));
}

TEST(ObjImport, GroupsNameEachTriangle) {
  const ImportedObj obj = import(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
      "f 1 2 3\n"
      "o table\nf 1 2 3\nf 2 4 3\n"
      "g leg 1\nf 1 2 4 3\n");
  EXPECT_EQ(obj.groupNames, (std::vector<std::string>{"", "table", "leg 1"}));
  EXPECT_EQ(obj.triangleGroups, (std::vector<uint32_t>{0, 1, 1, 2, 2}));
}

// ---- materials ----

const char* kMaterials =
    "# exported\n"
    "newmtl plastic\nKa 1 1 1\nKd 0.8 0.2 0.1\nKs 0.5 0.5 0.5\nNs 98\nNi 1.45\nd 1\nillum 2\n"
    "newmtl matte\nKd 0.5 0.5 0.5\nKs 0 0 0\nNs 0\nillum 1\n"
    "newmtl glass\nKd 0 0 0\nKs 1 1 1\nTf 0.9 1 0.9\nNs 1000\nNi 1.52\nd 0.2\nillum 7\n"
    "newmtl veil\nKd 1 1 1\nd 0.3\n"
    "newmtl lamp\nKd 0 0 0\nKe 5 4 3\n"
    "newmtl mirror\nKd 0 0 0\nKs 0.9 0.9 0.9\nNs 1000\nillum 3\n"
    "newmtl pbr\nKd 0.9 0.5 0.1\nPr 0.3\nPm 1\n";

const MaterialTextures& factorsOf(const ImportedObj& obj, const std::string& name) {
  for (const Material& m : obj.model.materials)
    if (m.name == name) return *m.textures();
  throw std::runtime_error("no material " + name);
}

TEST(ObjImport, MtlValuesMapOntoThePrincipledMaterial) {
  Files files;
  files.files["materials.mtl"] = kMaterials;
  std::string obj = "mtllib materials.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  for (const char* name : {"plastic", "matte", "glass", "veil", "lamp", "mirror", "pbr", "plastic", "missing"})
    obj += std::string("usemtl ") + name + "\nf 1 2 3\n";
  const ImportedObj imported = import(obj, files);
  EXPECT_EQ(files.asked, std::vector<std::string>{"materials.mtl"});
  // Triangles without usemtl, or naming no material, are the scene's to define.
  const std::vector<uint32_t> expected = {kNoObjMaterial, 0, 1, 2, 3, 4, 5, 6, 0, kNoObjMaterial};
  EXPECT_EQ(imported.model.meshes[0].mesh.materialIds, expected);
  ASSERT_EQ(imported.model.materials.size(), 7u);
  EXPECT_EQ(imported.model.materials[0].name, "plastic");
  EXPECT_TRUE(hasNote(imported.model, "usemtl \"missing\" names no material"));

  const PrincipledParams plastic = factorsOf(imported, "plastic").factors;
  EXPECT_EQ(plastic.baseColor, Spectrum(0.8f, 0.2f, 0.1f));
  EXPECT_EQ(plastic.metallic, 0.0f);
  // Ns 98: alpha = sqrt(2 / (98 + 2)) = 0.141421, roughness = sqrt(alpha) = 0.376060.
  EXPECT_NEAR(plastic.roughness, 0.376060f, 1e-6f);
  EXPECT_EQ(plastic.specular, 0.5f);  // max(Ks)
  EXPECT_FLOAT_EQ(plastic.ior, 1.45f);
  EXPECT_EQ(plastic.transmission, 0.0f);
  EXPECT_EQ(factorsOf(imported, "plastic").alphaMode, AlphaMode::kOpaque);
  EXPECT_FALSE(factorsOf(imported, "plastic").varies());

  const PrincipledParams matte = factorsOf(imported, "matte").factors;
  EXPECT_EQ(matte.specular, 0.0f);   // Ks 0 (and illum 1): purely diffuse
  EXPECT_EQ(matte.roughness, 1.0f);  // Ns 0
  EXPECT_EQ(matte.ior, 1.5f);        // no Ni

  const MaterialTextures& glass = factorsOf(imported, "glass");
  EXPECT_EQ(glass.factors.transmission, 1.0f);
  EXPECT_FLOAT_EQ(glass.factors.ior, 1.52f);
  EXPECT_EQ(glass.factors.metallic, 0.0f);
  EXPECT_EQ(glass.factors.baseColor, Spectrum(0.9f, 1.0f, 0.9f));  // Tf
  EXPECT_NEAR(glass.factors.roughness, 0.211369f, 1e-6f);          // Ns 1000: (2 / 1002)^(1/4)
  EXPECT_EQ(glass.alphaMode, AlphaMode::kOpaque);                  // d is not a cut-out on glass
  EXPECT_TRUE(hasNote(imported.model, "material \"glass\": d / map_d ignored"));

  const MaterialTextures& veil = factorsOf(imported, "veil");
  EXPECT_EQ(veil.alphaMode, AlphaMode::kMask);
  EXPECT_EQ(veil.alphaCutoff, 0.5f);
  EXPECT_FLOAT_EQ(veil.alphaFactor, 0.3f);
  EXPECT_TRUE(hasNote(imported.model, "material \"veil\": dissolve 0.3 (d): rendered as a cut-out"));

  const Material& lamp = imported.model.materials[4];
  EXPECT_EQ(lamp.name, "lamp");
  EXPECT_EQ(lamp.emission, Spectrum(5.0f, 4.0f, 3.0f));
  EXPECT_EQ(lamp.textures()->factors.baseColor, Spectrum(0.0f));

  const PrincipledParams mirror = factorsOf(imported, "mirror").factors;
  EXPECT_EQ(mirror.metallic, 1.0f);
  EXPECT_EQ(mirror.baseColor, Spectrum(0.9f));  // Kd black: the reflection colour Ks
  EXPECT_NEAR(mirror.roughness, 0.211369f, 1e-6f);

  const PrincipledParams pbr = factorsOf(imported, "pbr").factors;
  EXPECT_FLOAT_EQ(pbr.roughness, 0.3f);
  EXPECT_EQ(pbr.metallic, 1.0f);
}

TEST(ObjImport, EveryLibraryOfAnMtllibIsRead) {
  Files files;
  files.files["a.mtl"] = "newmtl red\nKd 1 0 0\n";
  files.files["lib/b c.mtl"] = "newmtl green\nKd 0 1 0\n";
  const ImportedObj obj = import(
      "mtllib a.mtl lib/b\\ c.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl green\nf 1 2 3\nusemtl red\nf 1 2 3\n", files);
  ASSERT_EQ(obj.model.materials.size(), 2u);
  EXPECT_EQ(obj.model.materials[0].textures()->factors.baseColor, Spectrum(0, 1, 0));
  EXPECT_EQ(obj.model.materials[1].textures()->factors.baseColor, Spectrum(1, 0, 0));
}

// A 2x2 RGB PNG: red, green / blue, grey 128.
std::string quadPng() { return test::png8(2, 2, 3, {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128}); }

TEST(ObjImport, TexturesAreReadRelativeToTheMtlFileAndDecodedByRole) {
  Files files;
  files.files["mats/wood.mtl"] =
      "newmtl wood\nmap_Kd -s 2 2 1 -o 0.5 0 0 tex/wood.png\nmap_Bump -bm 0.5 tex/normal.png\nmap_Ke tex/wood.png\n"
      "newmtl oak\nKd 0.5 0.5 0.5\nmap_Kd -clamp on tex/wood.png\nbump tex/height.png\nmap_Ks tex/wood.png\n";
  files.files["mats/tex/wood.png"] = quadPng();
  files.files["mats/tex/normal.png"] = test::png8(1, 1, 3, {128, 128, 255});
  files.files["mats/tex/height.png"] = test::png8(2, 1, 1, {10, 200});
  const ImportedObj obj = import(
      "mtllib mats/wood.mtl\n" + std::string(kQuad) + "usemtl wood\nf 1/1 2/2 3/3\nusemtl oak\nf 1/1 3/3 4/4\n", files);
  ASSERT_EQ(obj.model.materials.size(), 2u);

  const MaterialTextures& wood = *obj.model.materials[0].textures();
  ASSERT_TRUE(wood.baseColor);
  EXPECT_EQ(wood.factors.baseColor, Spectrum(1.0f));  // map_Kd without Kd: the map alone
  const Texture& kd = *wood.baseColor.texture;
  EXPECT_EQ(kd.name(), "models/mats/tex/wood.png");
  // Base colour is decoded from sRGB.
  EXPECT_EQ(kd.level(0).at(0, 0), Vec4(1, 0, 0, 1));
  EXPECT_EQ(kd.level(0).at(0, 1), Vec4(0, 0, 1, 1));
  EXPECT_FLOAT_EQ(kd.level(0).at(1, 1).r, srgbToLinear(128.0f / 255.0f));
  // -s 2 2 1 -o 0.5 0 0 in OBJ's v-up space: u' = 2u + 0.5, and with v flipped, v' = 2v + (1 - 2 - 0).
  EXPECT_EQ(wood.baseColor.transform.scale, Vec2(2.0f, 2.0f));
  EXPECT_EQ(wood.baseColor.transform.offset, Vec2(0.5f, -1.0f));
  // The normal map is data: linear; -bm is its scale.
  ASSERT_TRUE(wood.normal);
  EXPECT_FLOAT_EQ(wood.normal.texture->level(0).at(0, 0).r, 128.0f / 255.0f);
  EXPECT_EQ(wood.normalScale, 0.5f);
  // map_Ke without Ke: the map is the emission.
  ASSERT_TRUE(wood.emissive);
  EXPECT_EQ(obj.model.materials[0].emission, Spectrum(1.0f));

  const MaterialTextures& oak = *obj.model.materials[1].textures();
  EXPECT_EQ(oak.factors.baseColor, Spectrum(0.5f));
  // -clamp on: another texture object (its wrap differs); the same file without options is shared.
  ASSERT_TRUE(oak.baseColor);
  EXPECT_NE(oak.baseColor.texture, wood.baseColor.texture);
  EXPECT_EQ(oak.baseColor.texture->bilinear(Vec2(-5.0f, 0.25f), 0), Vec4(1, 0, 0, 1));
  EXPECT_TRUE(oak.baseColor.transform.identity());
  EXPECT_EQ(wood.emissive.texture, wood.baseColor.texture);
  // A grey bump map is a height map: not a normal map.
  EXPECT_FALSE(oak.normal);
  EXPECT_TRUE(hasNote(obj.model, "bump \"tex/height.png\" is a grey height map"));
  EXPECT_TRUE(hasNote(obj.model, "map_Ks \"tex/wood.png\" ignored"));
}

TEST(ObjImport, AlphaAndPbrMapsArePackedAsGltfDoes) {
  Files files;
  files.files["m.mtl"] =
      "newmtl leaf\nKd 1 1 1\nmap_Kd leaf.png\nmap_d mask.png\n"
      "newmtl metal\nmap_Pr rough.png\nmap_Pm metal.png\n";
  files.files["leaf.png"] = quadPng();
  files.files["mask.png"] = test::png8(1, 1, 1, {51});  // one texel, resampled to the colour's 2x2
  files.files["rough.png"] = test::png8(1, 1, 1, {102});
  files.files["metal.png"] = test::png8(1, 1, 1, {255});
  const ImportedObj obj = import(
      "mtllib m.mtl\n" + std::string(kQuad) + "usemtl leaf\nf 1/1 2/2 3/3\nusemtl metal\nf 1/1 3/3 4/4\n", files);
  const MaterialTextures& leaf = *obj.model.materials[0].textures();
  EXPECT_EQ(leaf.alphaMode, AlphaMode::kMask);
  EXPECT_EQ(leaf.alphaFactor, 1.0f);
  ASSERT_TRUE(leaf.baseColor);
  const RgbaImage& packed = leaf.baseColor.texture->level(0);
  ASSERT_EQ(packed.width, 2);
  EXPECT_EQ(Vec3(packed.at(0, 0)), Vec3(1, 0, 0));
  EXPECT_FLOAT_EQ(packed.at(0, 0).a, 51.0f / 255.0f);  // map_d is linear, in alpha
  EXPECT_FLOAT_EQ(packed.at(1, 1).r, srgbToLinear(128.0f / 255.0f));

  const MaterialTextures& metal = *obj.model.materials[1].textures();
  ASSERT_TRUE(metal.metallicRoughness);
  EXPECT_EQ(metal.factors.roughness, 1.0f);  // the maps alone
  EXPECT_EQ(metal.factors.metallic, 1.0f);
  const Vec4 mr = metal.metallicRoughness.texture->level(0).at(0, 0);
  EXPECT_FLOAT_EQ(mr.g, 102.0f / 255.0f);  // roughness in G
  EXPECT_EQ(mr.b, 1.0f);                   // metallic in B
}

// ---- errors ----

TEST(ObjImport, MissingFilesAreOneErrorNamingThem) {
  EXPECT_EQ(errorOf("v 0 0 0\nmtllib missing.mtl\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            "models/model.obj: line 2: mtllib \"missing.mtl\": cannot read \"models/missing.mtl\"");
  Files files;
  files.files["m.mtl"] = "# textures\nnewmtl wood\nKd 1 1 1\nmap_Kd tex/wood.png\n";
  const std::string obj = "mtllib m.mtl\n" + std::string(kQuad) + "usemtl wood\nf 1/1 2/2 3/3\n";
  EXPECT_EQ(errorOf(obj, files),
            "models/m.mtl: line 4: material \"wood\": map_Kd: cannot read texture \"models/tex/wood.png\"");
  // A texture that is there but broken names the material, the map and the problem.
  files.files["tex/wood.png"] = quadPng().substr(0, 40);
  const std::string message = errorOf(obj, files);
  EXPECT_EQ(
      message.rfind("models/m.mtl: line 4: material \"wood\": map_Kd \"tex/wood.png\": truncated or corrupt PNG", 0),
      0u)
      << message;
  files.files["tex/wood.png"] = "GIF89a";
  EXPECT_EQ(errorOf(obj, files),
            "models/m.mtl: line 4: material \"wood\": map_Kd \"tex/wood.png\": not a PNG, JPEG, HDR or EXR image "
            "(starts with 47 49 46 38)");
  // An unused material's textures are never read.
  files.files["tex/wood.png"] = quadPng();
  files.files["m.mtl"] += "newmtl unused\nmap_Kd nowhere.png\n";
  EXPECT_EQ(errorOf(obj, files), "");
}

TEST(ObjImport, BadReferencesAreOneErrorNamingTheLine) {
  EXPECT_EQ(errorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/5\n"),
            "models/model.obj: line 5: face refers to texture coordinate 5, but only 1 texture coordinate is defined "
            "before it");
  EXPECT_EQ(errorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\nvn 0 0 1\n"),
            "models/model.obj: line 4: face refers to normal 1, but no normal is defined before it");
  EXPECT_EQ(errorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nf 1//-3 2//1 3//1\n"),
            "models/model.obj: line 6: face refers to normal -3, but only 2 normals are defined before it");
  // What obj_check refuses: missing vertices, non-finite numbers.
  EXPECT_EQ(errorOf("v 0 0 0\nv 1 0 0\nf 1 2 3\n"),
            "models/model.obj: line 3: face refers to vertex 3, but only 2 vertices are defined before it");
  EXPECT_EQ(errorOf("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt nan 0\nf 1/1 2/1 3/1\n"),
            "models/model.obj: line 4: 'nan' is not a finite number");
  EXPECT_EQ(errorOf(""), "models/model.obj: empty file (0 bytes)");
}

TEST(ObjImport, BadMtlFilesAreOneErrorNamingThem) {
  Files files;
  files.files["m.mtl"] = std::string("newmtl a\nKd 1 1 1\n\x01\x02", 20);
  const std::string obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
  EXPECT_EQ(errorOf(obj, files), "models/m.mtl: binary data (byte 1 at offset 18), not an MTL text file");
  files.files["m.mtl"] = "newmtl a\nKd 1 -1 1\n";
  EXPECT_EQ(errorOf(obj, files), "models/m.mtl: line 2: material \"a\": Kd: negative colour component");
  files.files["m.mtl"] = "newmtl a\nd 1.5\n";
  EXPECT_EQ(errorOf(obj, files), "");  // d > 1 is opaque: nothing is cut
  files.files["m.mtl"] = "newmtl a\nd -0.5\n";
  EXPECT_EQ(errorOf(obj, files), "models/m.mtl: line 2: material \"a\": d: dissolve -0.5 is outside [0, 1]");
}

}  // namespace
}  // namespace lensfarm
