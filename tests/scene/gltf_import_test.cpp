// The glTF 2.0 importer (scene/gltf_import.h): small models written here as JSON with their
// buffers as a separate .bin (read through a ModelFileReader over a map), as data URIs, or as a
// .glb assembled byte by byte (glTF 2.0 §4.4), checked against values computed independently.
#include "common/scene/gltf_import.h"
#include "common/medium/medium.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/util/error.h"
#include "tests/support/gltf_builder.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

using test::base64;
using test::Builder;
using test::bytesOf;
using test::glbOf;
using test::kFloat;
using test::kUnsignedByte;
using test::kUnsignedShort;
const double kHalfSqrt2 = std::sqrt(0.5);
const double kPi = std::acos(-1.0);

// A 2 x 1 RGB PNG: a black texel, then a white one (0 and 1 whether decoded as sRGB or not).
const std::string kBlackWhitePng(
    "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x02\x00\x00\x00\x01\x08\x02\x00\x00"
    "\x00\x7b\x40\xe8\xdd\x00\x00\x00\x0f\x49\x44\x41\x54\x78\x9c\x63\x60\x60\x60\xf8\xff\xff\x3f\x00\x06\x01\x02\xfe"
    "\x02\xb2\x39\xae\x00\x00\x00\x00\x49\x45\x4e\x44\xae\x42\x60\x82",
    72);

// The unit cube [0, 1]^3: 8 vertices (i = x + 2y + 4z), 12 triangles facing out, vertex normals
// pointing away from the centre and uv = (x, y).
struct Cube {
  std::vector<float> positions, normals, uvs;
  std::vector<uint16_t> indices;
  Cube() {
    for (int i = 0; i < 8; ++i) {
      const float x = float(i & 1), y = float((i >> 1) & 1), z = float((i >> 2) & 1);
      positions.insert(positions.end(), {x, y, z});
      const float s = 1.0f / std::sqrt(3.0f);
      normals.insert(normals.end(), {(2 * x - 1) * s, (2 * y - 1) * s, (2 * z - 1) * s});
      uvs.insert(uvs.end(), {x, y});
    }
    const uint16_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (const auto& q : quads) indices.insert(indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  }
  // Mesh 0 of `b`: the cube with normals and uvs, material `material` (-1: none).
  int addTo(Builder& b, int material = -1) const {
    json primitive = {{"attributes",
                       {{"POSITION", b.floats(positions, "VEC3")},
                        {"NORMAL", b.floats(normals, "VEC3")},
                        {"TEXCOORD_0", b.floats(uvs, "VEC2")}}},
                      {"indices", b.indices(indices)}};
    if (material >= 0) primitive["material"] = material;
    if (!b.doc.contains("meshes")) b.doc["meshes"] = json::array();
    return b.add("meshes", {{"primitives", json::array({primitive})}});
  }
  DVec3 vertex(size_t i) const { return DVec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }
};

ModelFileReader readerOf(const std::map<std::string, std::string>& files, std::vector<std::string>* asked = nullptr) {
  return [files, asked](const std::string& path) -> std::optional<std::string> {
    if (asked) asked->push_back(path);
    const auto it = files.find(path);
    if (it == files.end()) return std::nullopt;
    return it->second;
  };
}
const ModelFileReader kNoFiles = [](const std::string&) -> std::optional<std::string> { return std::nullopt; };

// The InputError's message, or what else happened.
std::string errorOf(const std::string& bytes, const std::string& shown, const ModelFileReader& read = kNoFiles) {
  try {
    (void)importGltf(bytes, shown, read);
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("<not an InputError: ") + e.what() + ">";
  }
  return "<no error>";
}

bool hasNote(const ImportedModel& model, const std::string& part) {
  for (const std::string& n : model.notes)
    if (n.find(part) != std::string::npos) return true;
  return false;
}

void expectNear(const DVec3& actual, const DVec3& expected, double tolerance, const std::string& what) {
  EXPECT_NEAR(actual.x, expected.x, tolerance) << what;
  EXPECT_NEAR(actual.y, expected.y, tolerance) << what;
  EXPECT_NEAR(actual.z, expected.z, tolerance) << what;
}
DVec3 vec3Of(const json& j) { return DVec3(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()); }
// A 3-vector field of a camera or light object, to 1e-12.
void expectVec(const json& object, const char* key, const DVec3& expected) {
  expectNear(vec3Of(object.at(key)), expected, 1e-12, object.value("name", std::string()) + "." + key);
}

// The front-face normal of triangle t (cross(v1 - v0, v2 - v0), normalised).
DVec3 faceNormal(const MeshInput& in, size_t t) {
  const auto& idx = in.mesh.indices;
  const DVec3 &a = in.positions[idx[3 * t]], &b = in.positions[idx[3 * t + 1]], &c = in.positions[idx[3 * t + 2]];
  return glm::normalize(glm::cross(b - a, c - a));
}

// ------------------------------------------------------------------------------------------------
// Geometry and nodes

TEST(Gltf, NodeHierarchyPlacesTheCubeWhereTheComposedMatrixSays) {
  const Cube cube;
  Builder b;
  cube.addTo(b);
  cube.addTo(b);  // (each used once: placed in world space; a shared mesh is instanced, below)
  // nodes[0] translates by (10, 0, 0); its child nodes[1] scales by (2, 1, 1) then turns 90 degrees
  // about +y; its child nodes[2] has a matrix: scale 3, translate (0, 5, 0).
  b.doc["nodes"] = {
      {{"name", "parent"}, {"translation", {10, 0, 0}}, {"children", {1, 2}}},
      {{"name", "turned"}, {"rotation", {0, kHalfSqrt2, 0, kHalfSqrt2}}, {"scale", {2, 1, 1}}, {"mesh", 0}},
      {{"name", "matrix"}, {"matrix", {3, 0, 0, 0, 0, 3, 0, 0, 0, 0, 3, 0, 0, 5, 0, 1}}, {"mesh", 1}}};
  b.doc["scenes"] = {{{"nodes", {0}}}};
  b.doc["scene"] = 0;
  const ImportedModel model = importGltf(b.embedded(), "cube.gltf", kNoFiles);
  ASSERT_EQ(model.meshes.size(), 2u);
  const MeshInput &turned = model.meshes[0], &matrix = model.meshes[1];
  EXPECT_EQ(turned.mesh.name, "turned");
  EXPECT_EQ(matrix.mesh.name, "matrix");
  ASSERT_EQ(turned.positions.size(), 8u);
  ASSERT_EQ(matrix.positions.size(), 8u);
  for (size_t i = 0; i < 8; ++i) {
    const DVec3 p = cube.vertex(i);
    // Rotating (x, y, z) by 90 degrees about +y gives (z, y, -x); after the scale x is 2x.
    expectNear(turned.positions[i], DVec3(p.z + 10.0, p.y, -2.0 * p.x), 1e-12, "turned vertex " + std::to_string(i));
    expectNear(matrix.positions[i], DVec3(3.0 * p.x + 10.0, 3.0 * p.y + 5.0, 3.0 * p.z), 1e-12,
               "matrix vertex " + std::to_string(i));
  }
  EXPECT_EQ(turned.mesh.indices, std::vector<uint32_t>(cube.indices.begin(), cube.indices.end()));
  EXPECT_EQ(turned.mesh.materialIds, std::vector<uint32_t>(12, 0u));
  // No material: the glTF default material, appended.
  ASSERT_EQ(model.materials.size(), 1u);
  ASSERT_NE(model.materials[0].textures(), nullptr);
  EXPECT_EQ(model.materials[0].textures()->factors.baseColor, Spectrum(1.0f));
  EXPECT_EQ(model.materials[0].textures()->factors.metallic, 1.0f);
  EXPECT_EQ(model.materials[0].textures()->factors.roughness, 1.0f);
  expectNear(model.lo, DVec3(10.0, 0.0, -2.0), 1e-12, "lo");
  expectNear(model.hi, DVec3(13.0, 8.0, 3.0), 1e-12, "hi");
}

TEST(Gltf, ExternalBinEmbeddedAndGlbGiveIdenticalMeshes) {
  const Cube cube;
  Builder b;
  cube.addTo(b);
  b.doc["nodes"] = {{{"mesh", 0}, {"translation", {0.25, -1, 3}}, {"rotation", {0.1, 0.2, 0.3, 0.927362}}}};
  std::vector<std::string> asked;
  // The uri is percent-encoded (and has a '+', which is not a space in a path).
  const ImportedModel external =
      importGltf(b.gltf("cube%20data+1.bin"), "models/cube.gltf", readerOf({{"cube data+1.bin", b.bin}}, &asked));
  EXPECT_EQ(asked, std::vector<std::string>{"cube data+1.bin"});
  const ImportedModel embedded = importGltf(b.embedded(), "cube.gltf", kNoFiles);
  const ImportedModel binary = importGltf(b.glb(), "cube.glb", kNoFiles);
  for (const ImportedModel* other : {&embedded, &binary}) {
    ASSERT_EQ(other->meshes.size(), 1u);
    ASSERT_EQ(external.meshes.size(), 1u);
    const MeshInput &x = external.meshes[0], &y = other->meshes[0];
    EXPECT_EQ(x.positions, y.positions);
    EXPECT_EQ(x.mesh.indices, y.mesh.indices);
    EXPECT_EQ(x.mesh.normals, y.mesh.normals);
    EXPECT_EQ(x.mesh.uv[0], y.mesh.uv[0]);
    EXPECT_EQ(x.mesh.materialIds, y.mesh.materialIds);
    EXPECT_EQ(x.positions.size(), 8u);
    EXPECT_EQ(x.mesh.normals.size(), 8u);
    EXPECT_EQ(x.mesh.uv[0].size(), 8u);
    EXPECT_TRUE(x.mesh.uv[1].empty());
  }
  EXPECT_EQ(external.meshes[0].mesh.uv[0][3], Vec2(1.0f, 1.0f));
}

TEST(Gltf, NormalsUseTheInverseTransposeUnderNonUniformScale) {
  Builder b;
  // A triangle in the plane x + y = 0, its normal (1, 1, 0) / sqrt(2).
  const float s = float(kHalfSqrt2);
  const int position = b.floats({0, 0, 0, 0, 0, 1, 1, -1, 0}, "VEC3");
  const int normal = b.floats({s, s, 0, s, s, 0, s, s, 0}, "VEC3");
  b.doc["meshes"] = {{{"primitives", {{{"attributes", {{"POSITION", position}, {"NORMAL", normal}}}}}}}};
  b.doc["nodes"] = {{{"mesh", 0}, {"scale", {2, 1, 1}}}};
  const ImportedModel model = importGltf(b.embedded(), "n.gltf", kNoFiles);
  ASSERT_EQ(model.meshes.size(), 1u);
  const MeshInput& in = model.meshes[0];
  // Scaled, the triangle spans (0, 0, 1) and (2, -1, 0): its plane's normal is their cross product
  // (1, 2, 0), not the scaled normal (2, 1, 0).
  const DVec3 expected = glm::normalize(DVec3(1, 2, 0));
  expectNear(faceNormal(in, 0), expected, 1e-12, "geometric normal");
  ASSERT_EQ(in.mesh.normals.size(), 3u);
  for (const Vec3& n : in.mesh.normals) expectNear(glm::normalize(DVec3(n)), expected, 1e-6, "shading normal");
}

TEST(Gltf, MirroringMatrixFlipsWindingNormalsAndTangentHandedness) {
  Builder b;
  const int position = b.floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  const int normal = b.floats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
  const int tangent = b.floats({1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1}, "VEC4");
  b.doc["meshes"] = {
      {{"primitives", {{{"attributes", {{"POSITION", position}, {"NORMAL", normal}, {"TANGENT", tangent}}}}}}}};
  // Mirrors z (determinant -1) and moves the triangle off its plane.
  b.doc["nodes"] = {{{"mesh", 0}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1, 0, 0, 0, 2, 1}}}};
  const ImportedModel model = importGltf(b.embedded(), "m.gltf", kNoFiles);
  ASSERT_EQ(model.meshes.size(), 1u);
  const MeshInput& in = model.meshes[0];
  EXPECT_EQ(in.mesh.indices, (std::vector<uint32_t>{0, 2, 1}));
  // The face faced +z; its mirror image faces -z, with its winding swapped.
  expectNear(faceNormal(in, 0), DVec3(0, 0, -1), 1e-12, "geometric normal");
  for (const Vec3& n : in.mesh.normals) expectNear(DVec3(n), DVec3(0, 0, -1), 1e-7, "shading normal");
  // bitangent = cross(n, t) * w: (0, 1, 0) before, and the mirror keeps it, so w becomes -1.
  for (const glm::vec4& t : in.mesh.tangents) {
    expectNear(DVec3(t), DVec3(1, 0, 0), 1e-7, "tangent");
    EXPECT_EQ(t.w, -1.0f);
    expectNear(glm::cross(DVec3(in.mesh.normals[0]), DVec3(t)) * double(t.w), DVec3(0, 1, 0), 1e-7, "bitangent");
  }
  expectNear(in.positions[1], DVec3(1, 0, 2), 1e-12, "vertex 1");
}

TEST(Gltf, MeshUsedByThreeNodesIsOnePrototypeWithThreeInstances) {
  const Cube cube;
  Builder b;
  cube.addTo(b);
  b.doc["nodes"] = {{{"children", {1, 2, 3}}, {"translation", {0, 1, 0}}},
                    {{"mesh", 0}, {"translation", {0, 0, 0}}},
                    {{"mesh", 0}, {"translation", {5, 0, 0}}, {"name", "fifth"}},
                    {{"mesh", 0}, {"scale", {2, 2, 2}}, {"translation", {0, 0, -7}}}};
  b.doc["scenes"] = {{{"nodes", {0}}}};
  const ImportedModel model = importGltf(b.glb(), "three.glb", kNoFiles);
  EXPECT_TRUE(model.meshes.empty());
  ASSERT_EQ(model.prototypes.size(), 1u);
  // The prototype is the mesh as stored: its own space, its own normals.
  const MeshInput& prototype = model.prototypes[0];
  ASSERT_EQ(prototype.positions.size(), 8u);
  for (size_t i = 0; i < 8; ++i) EXPECT_EQ(prototype.positions[i], cube.vertex(i));
  EXPECT_EQ(prototype.mesh.triangleCount(), 12u);
  EXPECT_EQ(prototype.mesh.normals.size(), 8u);
  ASSERT_EQ(model.instances.size(), 3u);
  const DVec3 offsets[3] = {DVec3(0, 1, 0), DVec3(5, 1, 0), DVec3(0, 1, -7)};
  const double scales[3] = {1, 1, 2};
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(model.instances[k].prototype, 0u);
    for (size_t i = 0; i < 8; ++i)
      EXPECT_EQ(DVec3(model.instances[k].world * glm::dvec4(cube.vertex(i), 1.0)),
                scales[k] * cube.vertex(i) + offsets[k]);
  }
  EXPECT_EQ(model.instances[1].name, "fifth");
  // The model's bounds hold every use.
  expectNear(model.lo, DVec3(0, 1, -7), 0.0, "lo");
  expectNear(model.hi, DVec3(6, 3, 1), 0.0, "hi");
  EXPECT_TRUE(hasNote(model, "meshes[0]: used by 3 nodes: stored once and instanced"))
      << ::testing::PrintToString(model.notes);
}

TEST(Gltf, StripsFansAndPointsAndNormalizedTexcoords) {
  Builder b;
  // Four vertices of a unit square, z = 0; uvs as normalized UNSIGNED_BYTE (255 = 1) with a
  // byteStride of 4 (2 bytes of padding per vertex).
  const int position = b.floats({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, "VEC3");
  const std::string uvBytes = std::string("\x00\x00..\xff\x00..\x00\xff..\xff\x33..", 16);
  const int uv = b.accessor(b.view(uvBytes, 4), kUnsignedByte, 4, "VEC2", {{"normalized", true}});
  const json attributes = {{"POSITION", position}, {"TEXCOORD_1", uv}};
  const std::vector<uint8_t> order = {0, 1, 2, 3};
  const int indices = b.accessor(b.view(bytesOf(order)), kUnsignedByte, 4, "SCALAR");
  b.doc["meshes"] = {{{"primitives",
                       {{{"attributes", attributes}, {"mode", 5}, {"indices", indices}},
                        {{"attributes", attributes}, {"mode", 6}},
                        {{"attributes", attributes}, {"mode", 0}}}}}};
  b.doc["nodes"] = {{{"mesh", 0}}};
  const ImportedModel model = importGltf(b.embedded(), "modes.gltf", kNoFiles);
  ASSERT_EQ(model.meshes.size(), 1u);
  const TriangleMesh& mesh = model.meshes[0].mesh;
  // Strip 0 1 2 3: (0, 1, 2), (1, 3, 2); fan: (1, 2, 0), (2, 3, 0), its vertices after the strip's 4.
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 5, 6, 4, 6, 7, 4}));
  ASSERT_EQ(mesh.uv[1].size(), 8u);
  EXPECT_TRUE(mesh.uv[0].empty());
  EXPECT_EQ(mesh.uv[1][1], Vec2(1.0f, 0.0f));
  EXPECT_EQ(mesh.uv[1][3], Vec2(1.0f, float(0x33 / 255.0)));
  EXPECT_TRUE(hasNote(model, "meshes[0].primitives[2]: mode POINTS skipped")) << ::testing::PrintToString(model.notes);
}

// ------------------------------------------------------------------------------------------------
// Materials

TEST(Gltf, MaterialsMapFactorsAlphaModesAndExtensions) {
  const Cube cube;
  Builder b;
  cube.addTo(b, 0);
  b.doc["materials"] = {
      {{"name", "red"},
       {"pbrMetallicRoughness",
        {{"baseColorFactor", {0.8, 0.1, 0.2, 0.6}}, {"metallicFactor", 0.25}, {"roughnessFactor", 0.7}}},
       {"emissiveFactor", {1, 0.5, 0}},
       {"doubleSided", true},
       {"alphaMode", "MASK"},
       {"alphaCutoff", 0.3},
       {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4}}}}}},
      {{"name", "glass"},
       {"alphaMode", "BLEND"},
       {"extensions",
        {{"KHR_materials_transmission", {{"transmissionFactor", 0.9}}},
         {"KHR_materials_ior", {{"ior", 1.33}}},
         {"KHR_materials_specular", {{"specularFactor", 0.4}, {"specularColorFactor", {1, 0.5, 0.5}}}}}}},
      {{"pbrMetallicRoughness", {{"baseColorFactor", {0.2, 0.4, 0.6, 1}}, {"metallicFactor", 0.5}}},
       {"extensions", {{"KHR_materials_unlit", json::object()}}}}};
  b.doc["extensionsUsed"] = {
      "KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_ior",
      "KHR_materials_specular",          "KHR_materials_unlit",        "KHR_materials_clearcoat"};
  b.doc["nodes"] = {{{"mesh", 0}}};
  const ImportedModel model = importGltf(b.embedded(), "mat.gltf", kNoFiles);
  ASSERT_EQ(model.materials.size(), 3u);  // used or not, every material; no default needed

  const Material& red = model.materials[0];
  EXPECT_EQ(red.name, "red");
  EXPECT_EQ(red.emission, Spectrum(4.0f, 2.0f, 0.0f));
  EXPECT_TRUE(red.twoSidedEmission);  // doubleSided: emitting from both faces
  ASSERT_NE(red.textures(), nullptr);
  const MaterialTextures& r = *red.textures();
  EXPECT_EQ(r.factors.baseColor, Spectrum(0.8f, 0.1f, 0.2f));
  EXPECT_EQ(r.alphaFactor, 0.6f);
  EXPECT_EQ(r.factors.metallic, 0.25f);
  EXPECT_EQ(r.factors.roughness, 0.7f);
  EXPECT_EQ(r.factors.transmission, 0.0f);
  EXPECT_EQ(r.factors.ior, 1.5f);
  EXPECT_EQ(r.factors.specular, 1.0f);
  EXPECT_EQ(r.alphaMode, AlphaMode::kMask);
  EXPECT_EQ(r.alphaCutoff, 0.3f);
  EXPECT_FALSE(r.varies());

  const MaterialTextures& g = *model.materials[1].textures();
  EXPECT_EQ(model.materials[1].emission, Spectrum(0.0f));
  EXPECT_EQ(g.factors.baseColor, Spectrum(1.0f));
  EXPECT_EQ(g.factors.transmission, 0.9f);
  EXPECT_EQ(g.factors.ior, 1.33f);
  EXPECT_EQ(g.factors.specular, 0.4f);
  // specularColorFactor's luminance scales F0: 0.2126 + 0.5 (0.7152 + 0.0722).
  EXPECT_NEAR(g.factors.specularColor, 0.2126f + 0.5f * (0.7152f + 0.0722f), 1e-6f);
  EXPECT_FALSE(model.materials[1].twoSidedEmission);
  EXPECT_EQ(g.alphaMode, AlphaMode::kBlend);
  EXPECT_EQ(g.alphaCutoff, 0.5f);

  const MaterialTextures& u = *model.materials[2].textures();
  EXPECT_EQ(model.materials[2].name, "materials[2]");
  EXPECT_EQ(u.factors.baseColor, Spectrum(0.2f, 0.4f, 0.6f));
  EXPECT_EQ(u.factors.metallic, 0.0f);
  EXPECT_EQ(u.factors.specular, 0.0f);

  const std::string notes = ::testing::PrintToString(model.notes);
  EXPECT_TRUE(hasNote(model, "materials[1] \"glass\": alphaMode BLEND rendered as MASK with cutoff 0.5")) << notes;
  EXPECT_TRUE(hasNote(model, "materials[1] \"glass\": specularColorFactor approximated: F0 is scaled by its luminance"))
      << notes;
  EXPECT_TRUE(hasNote(model, "materials[2]: KHR_materials_unlit rendered as a Lambertian")) << notes;
  EXPECT_TRUE(hasNote(model, "extensionsUsed: KHR_materials_clearcoat not supported")) << notes;
  EXPECT_EQ(model.meshes[0].mesh.materialIds, std::vector<uint32_t>(12, 0u));
}

TEST(Gltf, KhrMaterialsVolumeGivesATransmittingMaterialItsAbsorbingInterior) {
  // attenuationColor c after attenuationDistance D: sigma_t = -ln(c) / D per channel, so the
  // medium passes exactly c over D (docs/media.md). Without transmission, or thin-walled
  // (thicknessFactor 0), the extension is noted and ignored; a bad distance is refused by name.
  const Cube cube;
  Builder b;
  cube.addTo(b, 0);
  const json volume = {{"thicknessFactor", 0.1}, {"attenuationDistance", 0.5}, {"attenuationColor", {0.9, 0.5, 0.25}}};
  b.doc["materials"] = {
      {{"name", "juice"},
       {"extensions",
        {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}}, {"KHR_materials_volume", volume}}}},
      {{"name", "paint"}, {"extensions", {{"KHR_materials_volume", volume}}}},
      {{"name", "film"},
       {"extensions",
        {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}},
         {"KHR_materials_volume", {{"attenuationColor", {0.5, 0.5, 0.5}}, {"attenuationDistance", 1.0}}}}}}};
  b.doc["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_volume"};
  b.doc["extensionsRequired"] = {"KHR_materials_volume"};
  b.doc["nodes"] = {{{"mesh", 0}}};
  const ImportedModel model = importGltf(b.embedded(), "volume.gltf", kNoFiles);
  ASSERT_EQ(model.materials.size(), 3u);
  ASSERT_NE(model.materials[0].interior, nullptr);
  const HomogeneousMedium* juice = model.materials[0].interior->asHomogeneous();
  ASSERT_NE(juice, nullptr);
  const Spectrum t = juice->transmittance(0.5f);
  EXPECT_NEAR(t.r, 0.9f, 1e-5f);
  EXPECT_NEAR(t.g, 0.5f, 1e-5f);
  EXPECT_NEAR(t.b, 0.25f, 1e-5f);
  EXPECT_EQ(juice->sigmaS(), Spectrum(0.0f));
  EXPECT_EQ(model.materials[1].interior, nullptr);
  EXPECT_EQ(model.materials[2].interior, nullptr);
  EXPECT_TRUE(hasNote(model, "KHR_materials_volume ignored (the material transmits no light)"))
      << ::testing::PrintToString(model.notes);

  b.doc["materials"][0]["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 0;
  try {
    importGltf(b.embedded(), "volume.gltf", kNoFiles);
    ADD_FAILURE() << "a zero attenuationDistance was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("materials[0].extensions.KHR_materials_volume.attenuationDistance"),
              std::string::npos)
        << e.what();
  }
}

TEST(Gltf, TexturesMapSlotsSamplersTransformsAndShareDecodes) {
  const Cube cube;
  Builder b;
  cube.addTo(b, 0);
  // images[0] in a bufferView (as a .glb holds it), images[1] in a data URI, images[2] a file.
  b.doc["images"] = {{{"bufferView", b.view(kBlackWhitePng)}, {"mimeType", "image/png"}},
                     {{"uri", "data:image/png;base64," + base64(kBlackWhitePng)}},
                     {{"uri", "textures/normal%20map.png"}}};
  b.doc["samplers"] = {{{"wrapS", 33071}, {"wrapT", 33648}, {"magFilter", 9728}}};
  b.doc["textures"] = {{{"source", 0}, {"sampler", 0}}, {{"source", 1}}, {{"source", 2}}};
  b.doc["materials"] = {{{"pbrMetallicRoughness",
                          {{"baseColorTexture",
                            {{"index", 0},
                             {"extensions",
                              {{"KHR_texture_transform",
                                {{"offset", {0.5, 0}}, {"rotation", 0.3}, {"scale", {2, 4}}, {"texCoord", 1}}}}}}},
                           {"metallicRoughnessTexture", {{"index", 0}}}}},
                         {"emissiveTexture", {{"index", 0}}},
                         {"emissiveFactor", {1, 1, 1}},
                         {"normalTexture", {{"index", 2}, {"scale", 0.5}}},
                         {"occlusionTexture", {{"index", 1}}}},
                        {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 1}, {"texCoord", 1}}}}}}};
  b.doc["nodes"] = {{{"mesh", 0}}};
  std::vector<std::string> asked;
  const ImportedModel model =
      importGltf(b.glb(), "tex.glb", readerOf({{"textures/normal map.png", kBlackWhitePng}}, &asked));
  EXPECT_EQ(asked, std::vector<std::string>{"textures/normal map.png"});
  ASSERT_EQ(model.materials.size(), 2u);
  const MaterialTextures& t = *model.materials[0].textures();
  ASSERT_TRUE(t.baseColor);
  EXPECT_EQ(t.baseColor.uvSet, 1);
  EXPECT_EQ(t.baseColor.transform.offset, Vec2(0.5f, 0.0f));
  EXPECT_EQ(t.baseColor.transform.scale, Vec2(2.0f, 4.0f));
  EXPECT_EQ(t.baseColor.transform.rotation, 0.3f);
  EXPECT_EQ(t.baseColor.texture->name(), "tex.glb: images[0]");
  EXPECT_EQ(t.baseColor.texture->width(), 2);
  EXPECT_EQ(t.baseColor.texture->height(), 1);
  // Base colour and emission are both sRGB with the same sampler: one Texture. The data roles
  // decode the same image as linear: another.
  EXPECT_EQ(t.emissive.texture, t.baseColor.texture);
  ASSERT_TRUE(t.metallicRoughness);
  EXPECT_NE(t.metallicRoughness.texture, t.baseColor.texture);
  EXPECT_EQ(t.metallicRoughness.uvSet, 0);
  EXPECT_TRUE(t.metallicRoughness.transform.identity());
  ASSERT_TRUE(t.normal);
  EXPECT_EQ(t.normalScale, 0.5f);
  EXPECT_EQ(t.normal.texture->name(), "tex.glb: images[2]");
  EXPECT_EQ(model.materials[0].emission, Spectrum(1.0f));
  EXPECT_TRUE(t.varies());
  // CLAMP_TO_EDGE and NEAREST: u = 1.25 reads the white right texel, u = 0.2 the black left one.
  EXPECT_EQ(t.baseColor.texture->sample(Vec2(1.25f, 0.5f)), Vec4(1.0f));
  EXPECT_EQ(t.baseColor.texture->sample(Vec2(0.2f, 0.5f)), Vec4(0.0f, 0.0f, 0.0f, 1.0f));
  // textures[1]: no sampler, so REPEAT: u = 1.125 reads what u = 0.125 reads.
  const MaterialTextures& second = *model.materials[1].textures();
  ASSERT_TRUE(second.baseColor);
  EXPECT_EQ(second.baseColor.uvSet, 1);
  EXPECT_EQ(second.baseColor.texture->sample(Vec2(1.125f, 0.5f)), second.baseColor.texture->sample(Vec2(0.125f, 0.5f)));
  EXPECT_TRUE(hasNote(model, "materials[0]: occlusionTexture ignored")) << ::testing::PrintToString(model.notes);
}

// ------------------------------------------------------------------------------------------------
// Cameras and lights

TEST(Gltf, CamerasAndPunctualLightsBecomeLensfarmJson) {
  Builder b;
  b.doc.erase("bufferViews");
  b.doc.erase("accessors");
  const double s = kHalfSqrt2;
  b.doc["cameras"] = {
      {{"name", "view"},
       {"type", "perspective"},
       {"perspective", {{"yfov", 0.8}, {"aspectRatio", 1.5}, {"znear", 0.1}}}},
      {{"type", "perspective"}, {"perspective", {{"yfov", 0.6}, {"znear", 0.1}}}},
      {{"type", "orthographic"}, {"orthographic", {{"xmag", 2}, {"ymag", 1}, {"znear", 0.1}, {"zfar", 10}}}}};
  b.doc["extensionsUsed"] = {"KHR_lights_punctual"};
  b.doc["extensions"] = {
      {"KHR_lights_punctual",
       {{"lights",
         {{{"name", "bulb"}, {"type", "point"}, {"color", {1, 0.5, 0.25}}, {"intensity", 8}, {"range", 20}},
          {{"type", "spot"}, {"intensity", 3}, {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}}}},
          {{"name", "sun"}, {"type", "directional"}, {"color", {1, 1, 0.5}}, {"intensity", 2}}}}}}};
  // Nodes: a camera at (1, 2, 3) turned 90 degrees about +y (looking along -x); the lights, the
  // spot and the sun turned -90 degrees about +x (shining down, -y).
  const json down = {-s, 0, 0, s};
  b.doc["nodes"] = {
      {{"camera", 0}, {"translation", {1, 2, 3}}, {"rotation", {0, s, 0, s}}},
      {{"name", "bulb node"}, {"translation", {0, 5, 0}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}},
      {{"name", "spot node"},
       {"translation", {0, 3, 0}},
       {"rotation", down},
       {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}},
      {{"rotation", down}, {"extensions", {{"KHR_lights_punctual", {{"light", 2}}}}}},
      {{"name", "second"}, {"camera", 1}},
      {{"camera", 2}}};
  const ImportedModel model = importGltf(b.doc.dump(), "lit.gltf", kNoFiles);
  EXPECT_TRUE(model.meshes.empty());

  ASSERT_EQ(model.cameras.size(), 3u);
  const json& c = model.cameras[0];
  EXPECT_EQ(c.at("type"), "pinhole");
  EXPECT_EQ(c.at("name"), "view");
  expectVec(c, "position", DVec3(1, 2, 3));
  // No mesh: look_at is 1 unit along the view direction, -z turned to -x.
  expectVec(c, "look_at", DVec3(0, 2, 3));
  expectVec(c, "up", DVec3(0, 1, 0));
  // yfov is the vertical angle (glTF 2.0 §3.10.2), with or without an aspectRatio, which is kept
  // only to compare with the image's.
  EXPECT_NEAR(c.at("angle_of_view").get<double>(), 0.8 * 180.0 / kPi, 1e-9);
  EXPECT_EQ(c.at("fov_axis"), "vertical");
  EXPECT_EQ(c.at("aspect_ratio"), 1.5);
  EXPECT_EQ(model.cameras[1].at("name"), "second");
  EXPECT_NEAR(model.cameras[1].at("angle_of_view").get<double>(), 0.6 * 180.0 / kPi, 1e-9);
  EXPECT_EQ(model.cameras[1].at("fov_axis"), "vertical");
  EXPECT_FALSE(model.cameras[1].contains("aspect_ratio"));
  EXPECT_EQ(model.cameras[2].at("type"), "orthographic");

  ASSERT_EQ(model.lights.size(), 3u);
  const json& point = model.lights[0];
  EXPECT_EQ(point.at("type"), "point");
  EXPECT_EQ(point.at("name"), "bulb");
  expectVec(point, "position", DVec3(0, 5, 0));
  // Candela and lux to W/sr and W/m^2 at 683 lm/W.
  expectVec(point, "intensity", DVec3(8, 4, 2) / 683.0);

  const json& spot = model.lights[1];
  EXPECT_EQ(spot.at("type"), "spot");
  EXPECT_EQ(spot.at("name"), "spot node");
  expectVec(spot, "position", DVec3(0, 3, 0));
  expectVec(spot, "look_at", DVec3(0, 2, 0));
  expectVec(spot, "intensity", DVec3(3, 3, 3) / 683.0);
  EXPECT_NEAR(spot.at("cone_angle").get<double>(), 0.5 * 180.0 / kPi, 1e-9);
  EXPECT_NEAR(spot.at("falloff_start").get<double>(), 0.2 * 180.0 / kPi, 1e-9);

  const json& sun = model.lights[2];
  EXPECT_EQ(sun.at("type"), "directional");
  EXPECT_EQ(sun.at("name"), "sun");
  // Its light travels down (-y); lensfarm's direction points towards the light: up.
  expectVec(sun, "direction", DVec3(0, 1, 0));
  expectVec(sun, "irradiance", DVec3(2, 2, 1) / 683.0);

  const std::string notes = ::testing::PrintToString(model.notes);
  EXPECT_TRUE(hasNote(model, "intensities in candela and lux converted")) << notes;
  EXPECT_TRUE(hasNote(model, "cameras[2]: orthographic")) << notes;
  EXPECT_TRUE(hasNote(model, "range ignored")) << notes;
}

TEST(Gltf, CameraLooksAtTheModelCentreDistance) {
  const Cube cube;
  Builder b;
  cube.addTo(b);
  b.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}}}}};
  b.doc["nodes"] = {{{"mesh", 0}}, {{"camera", 0}, {"translation", {0.5, 0.5, 10.5}}}};
  const ImportedModel model = importGltf(b.embedded(), "c.gltf", kNoFiles);
  ASSERT_EQ(model.cameras.size(), 1u);
  expectVec(model.cameras[0], "look_at", DVec3(0.5, 0.5, 0.5));
}

// ------------------------------------------------------------------------------------------------
// Bad input: one InputError naming the file and the element, never a crash.

struct BadModel {
  Cube cube;
  Builder b;
  BadModel() {
    cube.addTo(b);  // accessors: 0 POSITION, 1 NORMAL, 2 TEXCOORD_0, 3 indices
    b.doc["nodes"] = {{{"mesh", 0}}};
  }
};

// The error of the cube after `edit` of its document, as model.gltf (buffer in a data URI) or model.glb.
std::string errorAfter(const std::function<void(json&)>& edit, bool glb = false) {
  BadModel m;
  edit(m.b.doc);
  return glb ? errorOf(m.b.glb(), "model.glb") : errorOf(m.b.embedded(), "model.gltf");
}
// Whether `message` starts with `prefix` (the end of a message may add numbers).
::testing::AssertionResult startsWith(const std::string& message, const std::string& prefix) {
  if (message.rfind(prefix, 0) == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << message << "\" does not start with \"" << prefix << "\"";
}

TEST(Gltf, TruncatedOrForeignGlbIsRefused) {
  const BadModel m;
  const std::string glb = m.b.glb();
  EXPECT_EQ(errorOf(glb.substr(0, 100), "model.glb"), "model.glb: truncated glTF binary: its header says " +
                                                          std::to_string(glb.size()) + " bytes, the file has 100");
  EXPECT_EQ(errorOf(glb.substr(0, 7), "model.glb"),
            "model.glb: truncated glTF binary: 7 bytes, shorter than its 12-byte header");
  std::string magic = glb;
  magic[3] = 'X';
  EXPECT_EQ(errorOf(magic, "model.glb"),
            "model.glb: not a glTF binary: it starts with 67 6c 54 58, not the magic \"glTF\"");
  std::string version = glb;
  version[4] = 1;
  EXPECT_EQ(errorOf(version, "model.glb"), "model.glb: glTF binary version 1 is not supported (only version 2)");
  // Every prefix and a corrupted byte anywhere: an InputError or a model, nothing else.
  for (size_t n = 0; n < glb.size(); n += 3) {
    EXPECT_TRUE(startsWith(errorOf(glb.substr(0, n), "model.glb"), "model.glb: ")) << "prefix of " << n << " bytes";
  }
  for (size_t at = 0; at < glb.size(); ++at) {
    std::string corrupt = glb;
    corrupt[at] = char(corrupt[at] ^ 0x5a);
    const std::string e = errorOf(corrupt, "model.glb");
    EXPECT_TRUE(e == "<no error>" || e.rfind("model.glb", 0) == 0) << "byte " << at << ": " << e;
  }
}

TEST(Gltf, AccessorPastTheEndOfItsBufferIsRefused) {
  EXPECT_TRUE(startsWith(errorAfter([](json& d) { d["accessors"][0]["count"] = 100; }, true),
                         "model.glb: meshes[0].primitives[0]: accessor 0 reads past the end of buffer 0 (POSITION: "
                         "100 elements end at byte 1200 of "));
  // Inside the buffer but past its bufferView.
  EXPECT_TRUE(startsWith(errorAfter([](json& d) { d["accessors"][1]["byteOffset"] = 4; }, true),
                         "model.glb: meshes[0].primitives[0]: accessor 1 reads past the end of bufferView 1"));
  // A bufferView past its buffer.
  EXPECT_TRUE(startsWith(errorAfter(
                             [](json& d) {
                               d["bufferViews"][3]["byteLength"] = 4000;
                               d["accessors"][3]["count"] = 1;
                             },
                             true),
                         "model.glb: meshes[0].primitives[0]: bufferView 3 reads past the end of buffer 0"));
}

TEST(Gltf, BufferViewIndexOutOfRangeIsRefused) {
  EXPECT_EQ(errorAfter([](json& d) { d["accessors"][0]["bufferView"] = 7; }),
            "model.gltf: accessors[0].bufferView: bufferView 7 does not exist (the model has 4 bufferViews)");
  EXPECT_EQ(errorAfter([](json& d) { d["accessors"][3]["bufferView"] = 9; }),
            "model.gltf: accessors[3].bufferView: bufferView 9 does not exist (the model has 4 bufferViews)");
}

TEST(Gltf, IndexOutOfVertexRangeIsRefused) {
  Builder b;
  Cube cube;
  cube.indices[5] = 8;
  cube.addTo(b);
  b.doc["nodes"] = {{{"mesh", 0}}};
  EXPECT_EQ(errorOf(b.embedded(), "model.gltf"),
            "model.gltf: meshes[0].primitives[0]: indices (accessor 3): index 8 at position 5 is out of range "
            "(POSITION has 8 vertices)");
}

TEST(Gltf, NonFinitePositionIsRefused) {
  Builder b;
  Cube cube;
  cube.positions[3 * 2 + 1] = std::numeric_limits<float>::quiet_NaN();
  cube.addTo(b);
  b.doc["nodes"] = {{{"mesh", 0}}};
  EXPECT_EQ(errorOf(b.embedded(), "model.gltf"),
            "model.gltf: meshes[0].primitives[0]: POSITION (accessor 0): element 2 is not finite (0, nan, 0)");
}

TEST(Gltf, WrongComponentTypeIsRefused) {
  EXPECT_EQ(errorAfter([](json& d) {
              d["accessors"][1]["componentType"] = kUnsignedByte;
              d["accessors"][1]["count"] = 8;
            }),
            "model.gltf: meshes[0].primitives[0].attributes.NORMAL: accessor 1 is VEC3 of UNSIGNED_BYTE; NORMAL must "
            "be VEC3 of FLOAT");
}

TEST(Gltf, UnsupportedRequiredExtensionIsRefused) {
  EXPECT_EQ(errorAfter([](json& d) {
              d["extensionsUsed"] = {"KHR_draco_mesh_compression"};
              d["extensionsRequired"] = {"KHR_draco_mesh_compression"};
            }),
            "model.gltf: extensionsRequired: KHR_draco_mesh_compression is not supported");
}

TEST(Gltf, MissingExternalBinIsRefused) {
  const BadModel m;
  EXPECT_EQ(errorOf(m.b.gltf("cube.bin"), "model.gltf"), "model.gltf: buffers[0]: cannot read \"cube.bin\"");
  EXPECT_EQ(errorOf(m.b.gltf("cube.bin"), "model.gltf", readerOf({{"cube.bin", "short"}})),
            "model.gltf: buffers[0]: \"cube.bin\" has 5 bytes, byteLength says " + std::to_string(m.b.bin.size()));
}

// A material whose base colour texture is images[0], "wood.png", on `texCoord`.
void woodTexture(json& d, int texCoord) {
  d["images"] = {{{"uri", "wood.png"}}};
  d["textures"] = {{{"source", 0}}};
  d["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}, {"texCoord", texCoord}}}}}}};
}

TEST(Gltf, MissingImageIsRefusedWhenUsed) {
  EXPECT_EQ(errorAfter([](json& d) { woodTexture(d, 0); }), "model.gltf: images[0]: cannot read \"wood.png\"");
}

TEST(Gltf, TexCoordTwoIsRefused) {
  EXPECT_EQ(errorAfter([](json& d) { woodTexture(d, 2); }),
            "model.gltf: materials[0].pbrMetallicRoughness.baseColorTexture.texCoord: TEXCOORD_2 is not supported "
            "(only TEXCOORD_0 and TEXCOORD_1)");
}

TEST(Gltf, InvalidJsonIsRefused) {
  EXPECT_TRUE(startsWith(errorOf("{ \"asset\": ", "model.gltf"), "model.gltf: malformed JSON: parse error at line 1"));
  EXPECT_TRUE(startsWith(errorOf("", "model.gltf"), "model.gltf: malformed JSON"));
  EXPECT_EQ(errorOf("[1, 2]", "model.gltf"), "model.gltf: not a glTF model: its JSON is not an object");
  EXPECT_EQ(errorOf("{}", "model.gltf"), "model.gltf: asset: missing: not a glTF 2.0 model");
  EXPECT_EQ(errorOf(R"({"asset": {"version": "1.0"}})", "model.gltf"),
            "model.gltf: asset.version: \"1.0\": only glTF 2.0 is supported");
  const std::string deep = R"({"asset": {"version": "2.0"}, "extras": )" + std::string(100000, '[');
  EXPECT_EQ(errorOf(deep, "model.gltf"), "model.gltf: nested deeper than 64 levels");
  // A corrupted byte anywhere in a .gltf: an InputError or a model.
  BadModel m;
  const std::string text = m.b.embedded();
  for (size_t at = 0; at < text.size(); at += 2) {
    std::string corrupt = text;
    corrupt[at] = "0[\"}:,e-"[at % 8];
    const std::string e = errorOf(corrupt, "model.gltf");
    EXPECT_TRUE(e == "<no error>" || e.rfind("model.gltf", 0) == 0) << "byte " << at << ": " << e;
  }
}

TEST(Gltf, NodeGraphErrorsNameTheNode) {
  EXPECT_EQ(errorAfter([](json& d) {
              d["nodes"] = {{{"children", {1}}}, {{"children", {2}}}, {{"children", {1}}, {"mesh", 0}}};
            }),
            "model.gltf: nodes[1]: is a child of both nodes[0] and nodes[2]: a node has at most one parent");
  EXPECT_EQ(errorAfter([](json& d) {
              d["nodes"] = {{{"children", {1}}}, {{"mesh", 0}}};
              d["scenes"] = {{{"nodes", {1}}}};
            }),
            "model.gltf: scenes[0].nodes: node 1 is a child of nodes[0], not a root node");
  EXPECT_EQ(errorAfter([](json& d) {
              d["nodes"] = {{{"mesh", 0}, {"rotation", {0, 0, 0, 0}}}};
            }),
            "model.gltf: nodes[0].rotation: must be a unit quaternion [x, y, z, w], got [0, 0, 0, 0]");
  EXPECT_EQ(errorAfter([](json& d) {
              d["nodes"] = {{{"mesh", 3}}};
            }),
            "model.gltf: nodes[0].mesh: mesh 3 does not exist (the model has 1 mesh)");
}

TEST(Gltf, ReaderThatThrowsPassesItsErrorThrough) {
  const BadModel m;
  const ModelFileReader refusing = [](const std::string& path) -> std::optional<std::string> {
    throw InputError("scene.json: shapes[0].file", "\"" + path + "\" lies outside the scene's directory");
  };
  EXPECT_EQ(errorOf(m.b.gltf("../cube.bin"), "model.gltf", refusing),
            "scene.json: shapes[0].file: \"../cube.bin\" lies outside the scene's directory");
}

}  // namespace
}  // namespace lensfarm
