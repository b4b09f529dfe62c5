// SceneParser, shapes: the scene's `shapes` (models, quads, inline triangles), their transforms,
// and each mesh moved into render space (relative to the camera, in float) without its zero-area
// triangles.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "common/math/triangle.h"
#include "common/scene/scene_loader.h"
#include "common/scene/scene_parser.h"
#include "common/scene/transform.h"
#include "common/util/error.h"
#include "common/util/field_reader.h"

namespace lensfarm {

void SceneParser::parseShapes(FieldReader& top) {
  const json& shapes = top.raw("shapes");
  if (!shapes.is_array()) top.fail("shapes", "must be an array");
  for (size_t i = 0; i < shapes.size(); ++i) {
    FieldReader r(shapes[i], "shapes[" + std::to_string(i) + "]", fileName_);
    const std::string type = r.string("type");
    MeshInput mesh;
    mesh.mesh.name = r.string("name", type + "#" + std::to_string(i));
    mesh.mesh.visibleToCamera = r.boolean("visible_to_camera", true);
    if (isModelShapeType(type)) {
      addImportedShape(r, mesh, i);
    } else if (type == "quad") {
      const uint32_t material = materialRef(r, "material");
      addQuad(mesh, r.dvec3("corner"), r.dvec3("edge1"), r.dvec3("edge2"), material);
    } else if (type == "triangles") {
      readInlineTriangles(r, mesh);
    } else {
      r.fail(r.field("type"), "unknown shape type \"" + type + "\" (expected obj, gltf, usd, quad or triangles)");
    }
    // (A model's transform was applied when it was imported, to its cameras and lights too.)
    const Transform t = isModelShapeType(type) ? Transform{} : readTransform(r, "transform");
    r.finish();
    applyTransform(mesh, t);
    shapeTriangles_ += addMesh(std::move(mesh), r.path());
  }
}

void SceneParser::addQuad(MeshInput& in, DVec3 corner, DVec3 e1, DVec3 e2, uint32_t material) {
  // Faces the side of cross(e1, e2).
  TriangleMesh& mesh = in.mesh;
  const uint32_t base = uint32_t(in.positions.size());
  in.positions.insert(in.positions.end(), {corner, corner + e1, corner + e1 + e2, corner + e2});
  mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  mesh.materialIds.insert(mesh.materialIds.end(), {material, material});
}

void SceneParser::readInlineTriangles(FieldReader& r, MeshInput& in) {
  TriangleMesh& mesh = in.mesh;
  const uint32_t material = materialRef(r, "material");
  const json& verts = r.raw("vertices");
  if (!verts.is_array() || verts.size() < 3) r.fail(r.field("vertices"), "must be an array of at least 3 points");
  for (size_t k = 0; k < verts.size(); ++k)
    in.positions.push_back(r.toDVec3(verts[k], r.field("vertices") + "[" + std::to_string(k) + "]"));
  if (r.has("indices")) {
    const json& idx = r.raw("indices");
    if (!idx.is_array()) r.fail(r.field("indices"), "must be an array of [i, j, k] triples");
    for (size_t k = 0; k < idx.size(); ++k) {
      const std::string name = r.field("indices") + "[" + std::to_string(k) + "]";
      if (!idx[k].is_array() || idx[k].size() != 3) r.fail(name, "must be [i, j, k]");
      for (const json& v : idx[k]) {
        if (!v.is_number_unsigned() || v.get<uint64_t>() >= in.positions.size())
          r.fail(name, "vertex index out of range [0, " + std::to_string(in.positions.size()) + ")");
        mesh.indices.push_back(v.get<uint32_t>());
      }
      mesh.materialIds.push_back(material);
    }
  } else {
    if (verts.size() % 3 != 0) r.fail(r.field("vertices"), "without indices, must hold 3 points per triangle");
    for (uint32_t k = 0; k < verts.size(); ++k) mesh.indices.push_back(k);
    mesh.materialIds.assign(verts.size() / 3, material);
  }
}

void SceneParser::applyTransform(MeshInput& in, const Transform& t) {
  for (DVec3& p : in.positions) p = t.apply(p);
  const glm::dmat3 normalMatrix = t.normalMatrix();  // once, not per normal
  for (Vec3& n : in.mesh.normals) n = Vec3(normalMatrix * DVec3(n));
  // (A mirror reverses the bitangent w cross(n, t): w changes sign with the winding.)
  const float handedness = t.flipsHandedness() ? -1.0f : 1.0f;
  for (glm::vec4& v : in.mesh.tangents) v = glm::vec4(t.applyToVector(Vec3(v)), handedness * v.w);
  // A mirroring transform would turn every face inside out; swap winding to keep facing.
  if (t.flipsHandedness())
    for (size_t k = 0; k < in.mesh.indices.size(); k += 3) std::swap(in.mesh.indices[k + 1], in.mesh.indices[k + 2]);
}

Vec3 SceneParser::toRenderSpace(const DVec3& world, const std::string& field) const {
  const DVec3 d = world - scene_.origin;
  if (!(largestAbs(d) <= kMaxRenderDistance))
    throw InputError(fileName_,
                     field + ": lies " + shortNumber(glm::length(d)) + " from the camera; at most " +
                         shortNumber(kMaxRenderDistance) +
                         " (per axis) is supported (squared distances must stay finite in single precision)");
  return Vec3(d);
}

size_t SceneParser::addMesh(MeshInput in, const std::string& field) {
  TriangleMesh& mesh = in.mesh;
  mesh.positions.reserve(in.positions.size());
  for (size_t k = 0; k < in.positions.size(); ++k) {
    // (toRenderSpace's field is built only for a vertex it refuses.)
    const DVec3 d = in.positions[k] - scene_.origin;
    mesh.positions.push_back(largestAbs(d) <= kMaxRenderDistance
                                 ? Vec3(d)
                                 : toRenderSpace(in.positions[k], field + " vertex " + std::to_string(k)));
  }
  std::vector<DVec3>().swap(in.positions);
  const size_t count = dropDegenerateTriangles(mesh);
  finishAttributes(mesh);
  if (count > 0) scene_.meshes.push_back(std::move(mesh));
  return count;
}

size_t SceneParser::dropDegenerateTriangles(TriangleMesh& mesh) {
  const size_t triangles = mesh.triangleCount();
  size_t count = 0;
  for (size_t tri = 0; tri < triangles; ++tri) {
    const uint32_t* idx = &mesh.indices[3 * tri];
    // Zero area as the renderer will see the float vertices (math/triangle.h), at any size.
    if (!triangleNormal(mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]])) {
      ++scene_.skippedDegenerateTriangles;
      continue;
    }
    if (count != tri) {
      std::copy(idx, idx + 3, &mesh.indices[3 * count]);
      mesh.materialIds[count] = mesh.materialIds[tri];
    }
    ++count;
  }
  if (count < triangles) {
    mesh.indices.resize(3 * count), mesh.indices.shrink_to_fit();
    mesh.materialIds.resize(count), mesh.materialIds.shrink_to_fit();
  }
  return count;
}

void SceneParser::finishAttributes(TriangleMesh& mesh) {
  const auto unit = [](Vec3 v) {
    const float length = glm::length(v);
    return length > 0.0f && std::isfinite(length) ? v / length : Vec3(0.0f);
  };
  for (Vec3& n : mesh.normals) n = unit(n);
  for (glm::vec4& t : mesh.tangents) t = glm::vec4(unit(Vec3(t)), t.w < 0.0f ? -1.0f : 1.0f);
  if (mesh.normals.empty()) return;
  bool flat = true;
  for (size_t tri = 0; tri < mesh.triangleCount() && flat; ++tri) {
    const uint32_t* idx = &mesh.indices[3 * tri];
    const auto n = triangleNormal(mesh.positions[idx[0]], mesh.positions[idx[1]], mesh.positions[idx[2]]);
    for (int k = 0; k < 3 && flat; ++k) flat = n && glm::dot(*n, mesh.normals[idx[k]]) > 1.0f - 1e-6f;
  }
  if (flat) std::vector<Vec3>().swap(mesh.normals);
}

}  // namespace lensfarm
