// SceneParser, models: the model files (OBJ with MTL, glTF) the shapes name, imported in world
// space before the camera; their meshes that several nodes use, as prototypes and instances; and
// each model's shape, its meshes as one with its materials mapped.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "common/scene/asset_path.h"
#include "common/scene/gltf_import.h"
#include "common/scene/imported_model.h"
#include "common/scene/obj_check.h"
#include "common/scene/obj_import.h"
#include "common/scene/scene_loader.h"
#include "common/scene/scene_parser.h"
#include "common/scene/transform.h"
#include "common/scene/usd_import.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

namespace fs = std::filesystem;

void SceneParser::importModels(FieldReader& top) {
  const json& shapes = top.raw("shapes");
  if (!shapes.is_array()) top.fail("shapes", "must be an array");
  for (size_t i = 0; i < shapes.size(); ++i) {
    if (!shapes[i].is_object() || !shapes[i].contains("type")) continue;  // parseShapes reports it
    const json& type = shapes[i]["type"];
    if (!type.is_string() || !isModelShapeType(type.get<std::string>())) continue;
    ModelImport m;
    m.shape = i;
    m.field = "shapes[" + std::to_string(i) + "]";
    m.obj = type == "obj";
    FieldReader r(shapes[i], m.field, fileName_);
    const std::string rel = r.string("file");
    const bool usd = type == "usd";
    LoadedAsset file = readAssetFile(r, "file", m.obj ? "OBJ file" : usd ? "USD file" : "glTF file");
    m.shown = file.shown;
    const ModelFileReader read = modelFileReader(rel, m);
    if (m.obj) {
      // tinyobjloader skips what it does not understand: check first that this is an OBJ at all.
      // (Checked in place and moved on: the file's bytes become the text that is parsed.)
      ObjCheck check = checkObjTextInPlace(std::move(file.bytes));
      if (!check.ok()) r.fail(r.field("file"), "\"" + m.shown + "\": " + check.problem);
      ImportedObj obj = importCheckedObj(std::move(check.text), m.shown, read);
      m.model = std::move(obj.model);
      m.groupNames = std::move(obj.groupNames);
      m.triangleGroups = std::move(obj.triangleGroups);
    } else if (usd) {
      m.model = importUsd(std::move(file.bytes), m.shown, read);
    } else {
      m.model = importGltf(std::move(file.bytes), m.shown, read);
    }
    const Transform t = readTransform(r, "transform");
    transformModel(m, t);
    for (const std::string& note : m.readerNotes) notes_.push_back(m.shown + ": " + note);
    for (const std::string& note : m.model.notes) notes_.push_back(m.shown + ": " + note);
    imports_.push_back(std::move(m));
  }
}

ModelFileReader SceneParser::modelFileReader(const std::string& modelRel, ModelImport& m) {
  const fs::path dir = fs::path(modelRel).parent_path();
  return [this, dir, &m](const std::string& rel) -> std::optional<std::string> {
    if (const std::optional<std::string> problem = unreadablePathProblem(rel))
      throw InputError(m.shown, "\"" + rel + "\" " + *problem);
    const std::string path = (dir / rel).lexically_normal().generic_string();
    std::optional<std::string> content;
    try {
      content = readAsset_(path);
    } catch (const AssetRefused& e) {
      throw InputError(m.shown, "\"" + rel + "\" " + e.what());
    }
    if (!content) {
      if (m.obj && fs::path(rel).extension() == ".mtl") {
        m.readerNotes.push_back("mtllib " + rel + " not found: its materials must come from the scene");
        return std::string();
      }
      return std::nullopt;
    }
    addAssetHash(path, *content);
    return content;
  };
}

void SceneParser::transformModel(ModelImport& m, const Transform& t) {
  const auto point = [&](json& j, const char* key) {
    if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) return;
    const DVec3 p = t.apply(DVec3(j[key][0].get<double>(), j[key][1].get<double>(), j[key][2].get<double>()));
    j[key] = {p.x, p.y, p.z};
  };
  const auto vector = [&](json& j, const char* key) {
    if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) return;
    const Vec3 v = t.applyToVector(Vec3(j[key][0].get<float>(), j[key][1].get<float>(), j[key][2].get<float>()));
    j[key] = {v.x, v.y, v.z};
  };
  for (json& c : m.model.cameras) point(c, "position"), point(c, "look_at"), vector(c, "up");
  for (json& l : m.model.lights) {
    point(l, "position"), point(l, "look_at"), vector(l, "direction");
    point(l, "corner"), vector(l, "edge1"), vector(l, "edge2");  // a quad light (USD's RectLight)
  }
  for (MeshInput& in : m.model.meshes) {
    applyTransform(in, t);
    for (const DVec3& p : in.positions) m.worldLo = glm::min(m.worldLo, p), m.worldHi = glm::max(m.worldHi, p);
  }
  // Instances: the transform joins each node's; the bounds take each prototype's box as placed.
  std::vector<std::pair<DVec3, DVec3>> boxes;
  for (const MeshInput& in : m.model.prototypes) boxes.push_back(boundsOf(in.positions));
  for (ModelInstance& instance : m.model.instances) {
    instance.world = t.matrix * instance.world;
    const auto& [lo, hi] = boxes[instance.prototype];
    for (int c = 0; c < 8; ++c) {
      const DVec3 p(instance.world * glm::dvec4(boxCorner(lo, hi, c), 1.0));
      m.worldLo = glm::min(m.worldLo, p), m.worldHi = glm::max(m.worldHi, p);
    }
  }
}

template <typename MapMaterial>
void SceneParser::addPrototypes(FieldReader& r, ModelImport& m, bool instancing, bool visibleToCamera,
                                MapMaterial material, std::vector<MeshInput>& copies) {
  std::vector<uint32_t> sceneIndex(m.model.prototypes.size(), UINT32_MAX);
  std::vector<size_t> usesLeft(m.model.prototypes.size(), 0);
  for (const ModelInstance& instance : m.model.instances) ++usesLeft[instance.prototype];
  for (size_t k = 0; k < m.model.prototypes.size(); ++k) {
    MeshInput& in = m.model.prototypes[k];
    for (uint32_t& id : in.mesh.materialIds) id = material(id);
    const bool emits = std::any_of(in.mesh.materialIds.begin(), in.mesh.materialIds.end(),
                                   [&](uint32_t id) { return scene_.materials[id].isEmissive(); });
    if (emits && instancing)
      notes_.push_back(m.shown + ": mesh \"" + in.mesh.name + "\" emits light: copied for each of its " +
                       std::to_string(usesLeft[k]) + " uses (each copy is a light to sample)");
    if (emits || !instancing) continue;
    // In object space: the float positions are the object's; zero-area triangles there dropped.
    MeshInput object = std::move(in);
    sceneIndex[k] = uint32_t(scene_.prototypes.size());
    TriangleMesh& mesh = object.mesh;
    for (const DVec3& p : object.positions) {
      if (!(largestAbs(p) <= kMaxRenderDistance))
        r.fail(r.field("file"), "\"" + m.shown + "\": mesh \"" + mesh.name + "\" has a vertex " + showVec3(p) +
                                    " beyond " + shortNumber(kMaxRenderDistance) + " in its own space");
      mesh.positions.push_back(Vec3(p));
    }
    std::vector<DVec3>().swap(object.positions);
    dropDegenerateTriangles(mesh);
    finishAttributes(mesh);
    scene_.prototypes.push_back(std::move(mesh));
  }
  // Each kept prototype's box, once.
  const uint32_t firstPrototype =
      uint32_t(scene_.prototypes.size()) -
      uint32_t(std::count_if(sceneIndex.begin(), sceneIndex.end(), [](uint32_t index) { return index != UINT32_MAX; }));
  std::vector<std::pair<Vec3, Vec3>> boxes;
  for (size_t k = firstPrototype; k < scene_.prototypes.size(); ++k)
    boxes.push_back(boundsOf(scene_.prototypes[k].positions));
  for (const ModelInstance& instance : m.model.instances) {
    const uint32_t k = instance.prototype;
    const bool last = --usesLeft[k] == 0;
    if (sceneIndex[k] == UINT32_MAX) {
      // A copy in world space (the last use takes the prototype's arrays).
      MeshInput copy;
      if (last)
        copy = std::move(m.model.prototypes[k]);
      else
        copy = m.model.prototypes[k];
      copy.mesh.name = instance.name;
      applyTransform(copy, Transform{instance.world});
      copies.push_back(std::move(copy));
      continue;
    }
    if (scene_.prototypes[sceneIndex[k]].triangleCount() == 0) continue;
    addInstance(r, sceneIndex[k], boxes[sceneIndex[k] - firstPrototype], instance, visibleToCamera, m.shown);
  }
  std::vector<MeshInput>().swap(m.model.prototypes);
  std::vector<ModelInstance>().swap(m.model.instances);
}

void SceneParser::addInstance(FieldReader& r, uint32_t prototype, const std::pair<Vec3, Vec3>& box,
                              const ModelInstance& instance, bool visibleToCamera, const std::string& shown) {
  const TriangleMesh& mesh = scene_.prototypes[prototype];
  glm::dmat4 world = instance.world;
  world[3] = glm::dvec4(DVec3(world[3]) - scene_.origin, 1.0);
  const auto& [lo, hi] = box;
  for (int c = 0; c < 8; ++c) {
    const DVec3 p(world * glm::dvec4(DVec3(boxCorner(lo, hi, c)), 1.0));
    if (!(largestAbs(p) <= kMaxRenderDistance))
      r.fail(r.field("file"), "\"" + shown + "\": instance \"" + instance.name + "\" of mesh \"" + mesh.name +
                                  "\" reaches " + shortNumber(glm::length(p)) + " from the camera; at most " +
                                  shortNumber(kMaxRenderDistance) + " (per axis) is supported");
  }
  const glm::dmat3 linear(world);
  const double det = glm::determinant(linear);
  MeshInstance out;
  out.prototype = prototype;
  out.toRender = glm::mat4x3(world);
  out.normalMatrix = glm::mat3(cofactorMatrix(linear) * (det < 0.0 ? -1.0 : 1.0));
  out.mirrors = det < 0.0;
  out.visibleToCamera = visibleToCamera;
  out.name = instance.name;
  scene_.instances.push_back(std::move(out));
  instancedTriangles_ += mesh.triangleCount();
}

// The materials of a model's shape: the shape's material for all of it and its fallback (each
// UINT32_MAX when not given), its overrides by the model's material name and, for OBJ, by group,
// with the names the triangles used, and the model's material k's index in the scene's.
struct SceneParser::ShapeMaterials {
  uint32_t all = UINT32_MAX;
  uint32_t fallback = UINT32_MAX;  // for triangles that have no material otherwise
  size_t fellBack = 0;
  std::map<std::string, uint32_t> byName, byGroup;
  std::set<std::string> namesUsed, groupsUsed;
  std::vector<uint32_t> modelToScene;
};

SceneParser::ShapeMaterials SceneParser::readShapeMaterials(FieldReader& r, ModelImport& m) {
  ShapeMaterials s;
  s.all = r.has("material") ? materialRef(r, "material") : UINT32_MAX;
  // For triangles that have no material otherwise (an OBJ without usemtl, or without its .mtl).
  s.fallback = r.has("fallback_material") ? materialRef(r, "fallback_material") : UINT32_MAX;
  // Overrides by the model's material name ("materials") and, for OBJ, by group.
  const auto readOverrides = [&](const char* key, std::map<std::string, uint32_t>& into) {
    if (!r.has(key)) return;
    FieldReader g(r.raw(key), r.field(key), fileName_);
    const json& object = r.raw(key);
    for (auto it = object.begin(); it != object.end(); ++it)
      into[it.key()] = lookupMaterial(r, g.field(it.key()), g.string(it.key()));
    g.finish();
  };
  readOverrides("materials", s.byName);
  if (m.obj) readOverrides("group_materials", s.byGroup);
  // The model's materials join the scene's, named after the model.
  const uint32_t first = uint32_t(scene_.materials.size());
  for (Material mat : m.model.materials) {
    mat.name = m.shown + ": " + mat.name;
    scene_.materials.push_back(std::move(mat));
  }
  s.modelToScene.resize(m.model.materials.size());
  for (size_t k = 0; k < m.model.materials.size(); ++k) {
    const std::string& name = m.model.materials[k].name;
    s.modelToScene[k] = first + uint32_t(k);
    if (auto it = s.byName.find(name); it != s.byName.end()) s.modelToScene[k] = it->second, s.namesUsed.insert(name);
  }
  for (const auto& [name, id] : s.byName)
    if (!s.namesUsed.count(name))
      r.fail(r.field("materials") + "." + name, "no material of that name in \"" + m.shown + "\"");
  return s;
}

uint32_t SceneParser::triangleMaterial(FieldReader& r, const ModelImport& m, ShapeMaterials& s, uint32_t id,
                                       size_t triangle) {
  uint32_t material = s.all;
  if (m.obj) {
    const std::string& group = m.groupNames[m.triangleGroups[triangle]];
    if (auto it = s.byGroup.find(group); it != s.byGroup.end()) {
      material = it->second;
      s.groupsUsed.insert(group);
    } else if (material == UINT32_MAX && id != kNoObjMaterial) {
      material = s.modelToScene[id];
    }
    if (material == UINT32_MAX && s.fallback != UINT32_MAX) material = s.fallback, ++s.fellBack;
    if (material == UINT32_MAX)
      r.fail(r.field("material"), "OBJ group \"" + group + "\" has no material: give material or group_materials." +
                                      group + " (or a usemtl with an mtllib)");
  } else if (material == UINT32_MAX) {
    material = s.modelToScene[id];
  }
  return material;
}

void SceneParser::mergeShapeMeshes(FieldReader& r, ModelImport& m, ShapeMaterials& s, size_t firstCopy,
                                   MeshInput& out) {
  TriangleMesh& mesh = out.mesh;
  const bool anyNormals = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                                      [](const MeshInput& in) { return !in.mesh.normals.empty(); });
  bool anyUv[2];
  for (int set = 0; set < 2; ++set)
    anyUv[set] = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                             [set](const MeshInput& in) { return !in.mesh.uv[set].empty(); });
  const bool anyTangents = std::any_of(m.model.meshes.begin(), m.model.meshes.end(),
                                       [](const MeshInput& in) { return !in.mesh.tangents.empty(); });
  size_t triangle = 0;
  for (size_t part = 0; part < m.model.meshes.size(); ++part) {
    MeshInput& in = m.model.meshes[part];
    const uint32_t base = uint32_t(out.positions.size());
    const size_t vertices = in.positions.size();
    appendAndFree(out.positions, in.positions);
    // Attributes a part lacks where another has them: its face normals are taken from the
    // geometry (zero: the shading code falls back to the geometric normal), uv 0.
    if (anyNormals) {
      if (in.mesh.normals.empty()) in.mesh.normals.assign(vertices, Vec3(0.0f));
      appendAndFree(mesh.normals, in.mesh.normals);
    }
    for (int set = 0; set < 2; ++set) {
      if (!anyUv[set]) continue;
      if (in.mesh.uv[set].empty()) in.mesh.uv[set].assign(vertices, Vec2(0.0f));
      appendAndFree(mesh.uv[set], in.mesh.uv[set]);
    }
    if (anyTangents) {
      if (in.mesh.tangents.empty()) in.mesh.tangents.assign(vertices, glm::vec4(0.0f));
      appendAndFree(mesh.tangents, in.mesh.tangents);
    }
    for (uint32_t& index : in.mesh.indices) index += base;
    appendAndFree(mesh.indices, in.mesh.indices);
    for (uint32_t& id : in.mesh.materialIds) {
      if (part >= firstCopy) continue;
      id = triangleMaterial(r, m, s, id, triangle);
      ++triangle;
    }
    appendAndFree(mesh.materialIds, in.mesh.materialIds);
  }
}

void SceneParser::addImportedShape(FieldReader& r, MeshInput& out, size_t shapeIndex) {
  ModelImport* found = nullptr;
  for (ModelImport& m : imports_)
    if (m.shape == shapeIndex) found = &m;
  (void)r.has("file");
  (void)r.has("transform");  // read (and applied) by importModels
  ModelImport& m = *found;
  ShapeMaterials s = readShapeMaterials(r, m);

  // Meshes that several nodes use: instances, or copies that join the shape's meshes (their
  // materials mapped already).
  size_t firstCopy = SIZE_MAX;
  {
    const bool instancing = r.boolean("instancing", true);
    std::vector<MeshInput> copies;
    addPrototypes(
        r, m, instancing, out.mesh.visibleToCamera,
        [&](uint32_t id) { return s.all != UINT32_MAX ? s.all : s.modelToScene[id]; }, copies);
    firstCopy = m.model.meshes.size();
    for (MeshInput& copy : copies) m.model.meshes.push_back(std::move(copy));
  }
  // One mesh (one Embree geometry) for the whole shape, as an OBJ always was.
  mergeShapeMeshes(r, m, s, firstCopy, out);
  std::vector<MeshInput>().swap(m.model.meshes);  // spent: each part was moved or copied and freed
  std::vector<uint32_t>().swap(m.triangleGroups);
  for (const auto& [group, material] : s.byGroup)
    if (!s.groupsUsed.count(group))
      r.fail(r.field("group_materials") + "." + group, "no group of that name in \"" + m.shown + "\"");
  if (s.fellBack > 0)
    notes_.push_back(m.shown + ": " + std::to_string(s.fellBack) + " triangle(s) without a material use \"" +
                     scene_.materials[s.fallback].name + "\"");
}

}  // namespace lensfarm
