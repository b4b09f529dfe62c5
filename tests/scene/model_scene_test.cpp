// Models as scenes render what the equivalent JSON scene renders: the Cornell box written as a
// glTF and as an OBJ with an MTL (both by this test, from the JSON scene's own triangles) against
// the JSON scene, statistically; a .glb and the same .gltf give identical bits.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The Cornell box (cornell-classic) at a test's size: the JSON scene, and its triangles grouped by
// material in world space.
struct Cornell {
  json scene;
  struct Part {
    std::string material;
    Spectrum albedo;
    std::vector<DVec3> positions;  // 3 per triangle
  };
  std::vector<Part> parts;

  Cornell() {
    scene = test::bundledSceneJson("cornell-classic.json");
    scene["render"]["resolution"] = {24, 24};
    scene["render"]["samples_per_pixel"] = 64;
    test::TempDir dir;
    const Scene s = test::loadSceneJson(dir, scene);
    std::map<uint32_t, size_t> partOf;
    for (const TriangleMesh& mesh : s.meshes) {
      for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const Material& m = s.materials[mesh.materialIds[t]];
        if (m.isEmissive()) continue;  // the lights stay in the scene's "lights"
        auto [it, added] = partOf.try_emplace(mesh.materialIds[t], parts.size());
        if (added) parts.push_back(Part{m.name, m.albedo(), {}});
        for (int k = 0; k < 3; ++k)
          parts[it->second].positions.push_back(DVec3(mesh.positions[mesh.indices[3 * t + k]]) + s.origin);
      }
    }
  }

  // The scene with the box replaced by `shape` (its materials come from the model).
  json withShape(const json& shape) const {
    json out = scene;
    out["shapes"] = json::array({shape});
    out.erase("materials");
    return out;
  }

  // The box as glTF: one primitive per material, each a principled material that is exactly
  // Lambertian (metallic 0, KHR_materials_specular's specularFactor 0).
  test::Builder gltf() const {
    test::Builder b;
    b.doc["materials"] = json::array();
    json primitives = json::array();
    for (size_t i = 0; i < parts.size(); ++i) {
      std::vector<float> p;
      for (const DVec3& v : parts[i].positions) p.insert(p.end(), {float(v.x), float(v.y), float(v.z)});
      const Spectrum& a = parts[i].albedo;
      b.add("materials",
            {{"name", parts[i].material},
             {"pbrMetallicRoughness", {{"baseColorFactor", {a.r, a.g, a.b, 1.0}}, {"metallicFactor", 0.0}}},
             {"extensions", {{"KHR_materials_specular", {{"specularFactor", 0.0}}}}}});
      primitives.push_back({{"attributes", {{"POSITION", b.floats(p, "VEC3")}}}, {"material", int(i)}});
    }
    b.doc["extensionsUsed"] = {"KHR_materials_specular"};
    b.doc["meshes"] = json::array({{{"primitives", primitives}}});
    b.doc["nodes"] = json::array({{{"mesh", 0}}});
    b.doc["scenes"] = json::array({{{"nodes", {0}}}});
    b.doc["scene"] = 0;
    return b;
  }

  // The box as OBJ with an MTL library: one usemtl group per material, Kd = albedo, Ks 0.
  std::pair<std::string, std::string> objAndMtl() const {
    std::ostringstream obj, mtl;
    obj.precision(17);
    mtl.precision(9);
    obj << "mtllib box.mtl\n";
    size_t vertex = 1;
    for (const Part& part : parts) {
      mtl << "newmtl " << part.material << "\nKd " << part.albedo.r << " " << part.albedo.g << " " << part.albedo.b
          << "\nKs 0 0 0\nNs 10\nillum 2\n";
      obj << "o " << part.material << "\nusemtl " << part.material << "\n";
      for (const DVec3& v : part.positions) obj << "v " << v.x << " " << v.y << " " << v.z << "\n";
      for (size_t t = 0; t < part.positions.size() / 3; ++t, vertex += 3)
        obj << "f " << vertex << " " << vertex + 1 << " " << vertex + 2 << "\n";
    }
    return {obj.str(), mtl.str()};
  }
};

void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

Scene loadIn(const test::TempDir& dir, const json& scene) { return test::loadSceneJson(dir, scene); }

// The box as `shape` (files in `dir`) and the JSON scene agree pixel by pixel and in their means,
// over 16 renders each (a 2 % change of every albedo fails it).
void expectRendersLikeTheJsonScene(const Cornell& box, const test::TempDir& dir, const json& shape) {
  const Scene model = loadIn(dir, box.withShape(shape));
  const Scene reference = loadIn(dir, box.scene);
  test::expectSameImage(test::renderStatistics(model, 16), test::renderStatistics(reference, 16));
}

TEST(ModelScene, CornellBoxAsGltfRendersLikeTheJsonScene) {
  const Cornell box;
  ASSERT_EQ(box.parts.size(), 7u);
  test::TempDir dir;
  const test::Builder b = box.gltf();
  writeFile(dir.path() / "box.bin", b.bin);
  writeFile(dir.path() / "box.gltf", b.gltf("box.bin"));
  expectRendersLikeTheJsonScene(box, dir, {{"type", "gltf"}, {"file", "box.gltf"}});
}

TEST(ModelScene, CornellBoxAsObjWithMtlRendersLikeTheJsonScene) {
  const Cornell box;
  test::TempDir dir;
  const auto [obj, mtl] = box.objAndMtl();
  writeFile(dir.path() / "box.obj", obj);
  writeFile(dir.path() / "box.mtl", mtl);
  expectRendersLikeTheJsonScene(box, dir, {{"type", "obj"}, {"file", "box.obj"}});
}

TEST(ModelScene, GlbAndGltfRenderIdenticalBits) {
  const Cornell box;
  test::TempDir dir;
  const test::Builder b = box.gltf();
  writeFile(dir.path() / "box.bin", b.bin);
  writeFile(dir.path() / "box.gltf", b.gltf("box.bin"));
  writeFile(dir.path() / "box.glb", b.glb());
  const Image gltf = test::renderScene(loadIn(dir, box.withShape({{"type", "gltf"}, {"file", "box.gltf"}}))).image;
  const Image glb = test::renderScene(loadIn(dir, box.withShape({{"type", "gltf"}, {"file", "box.glb"}}))).image;
  ASSERT_EQ(gltf.rgb.size(), glb.rgb.size());
  EXPECT_EQ(std::memcmp(gltf.rgb.data(), glb.rgb.data(), gltf.rgb.size() * sizeof(float)), 0);
}

TEST(ModelScene, AnObjWithoutMaterialsRendersInTheDefaultGrey) {
  // An OBJ exported with an mtllib that did not come along, and faces before any usemtl.
  test::TempDir dir;
  writeFile(dir.path() / "part.obj", "mtllib part.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl steel\nf 1 3 2\n");
  std::string text;
  const Scene scene = modelScene(dir.path() / "part.obj", text);
  ASSERT_EQ(scene.meshes.size(), 1u);
  for (uint32_t id : scene.meshes[0].materialIds) EXPECT_EQ(scene.materials[id].name, "default grey");
  std::string notes;
  for (const std::string& n : scene.notes) notes += n + "\n";
  EXPECT_NE(notes.find("mtllib part.mtl not found"), std::string::npos) << notes;
  EXPECT_NE(notes.find("2 triangle(s) without a material use \"default grey\""), std::string::npos) << notes;
}

TEST(ModelScene, AModelCameraIsChosenByName) {
  // Two cameras, "front" at z = 5 and "side" at x = 5, both looking at the origin (a node's -z).
  test::TempDir dir;
  test::Builder b;
  const std::vector<float> p = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
  b.doc["meshes"] = json::array({{{"primitives", {{{"attributes", {{"POSITION", b.floats(p, "VEC3")}}}}}}}});
  b.doc["cameras"] =
      json::array({{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"aspectRatio", 1.0}, {"znear", 0.1}}}},
                   {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"aspectRatio", 1.0}, {"znear", 0.1}}}}});
  const double s = std::sqrt(0.5);
  b.doc["nodes"] =
      json::array({{{"mesh", 0}},
                   {{"name", "front"}, {"camera", 0}, {"translation", {0, 0, 5}}},
                   {{"name", "side"}, {"camera", 1}, {"translation", {5, 0, 0}}, {"rotation", {0, s, 0, s}}}});
  b.doc["scenes"] = json::array({{{"nodes", {0, 1, 2}}}});
  writeFile(dir.path() / "two.glb", b.glb());
  const auto positionOf = [&](const std::optional<std::string>& camera) {
    std::string text;
    const Scene scene = modelScene(dir.path() / "two.glb", text, {}, camera);
    return scene.origin;  // render space is centred on the camera
  };
  const DVec3 first = positionOf(std::nullopt), side = positionOf("side");
  EXPECT_NEAR(glm::length(first - DVec3(0, 0, 5)), 0.0, 1e-9);
  EXPECT_NEAR(glm::length(side - DVec3(5, 0, 0)), 0.0, 1e-9);
  try {
    positionOf("top");
    ADD_FAILURE() << "an unknown camera name loads";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no model camera named \"top\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"front\", \"side\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lensfarm
