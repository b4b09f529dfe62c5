#pragma once
// What a model file (glTF 2.0, OBJ with MTL) brings into a scene, in the file's own world space,
// before the scene loader moves it to render space (scene/scene.h): meshes with their vertex
// attributes, materials with textures, and the cameras and lights, written as lensfarm scene JSON
// so that the scene loader checks them like any scene's (docs/scene-format.md).
//
// Importers (scene/gltf_import.h, scene/obj_import.h) read every file they need through a
// ModelFileReader, so the scene loader hashes them and ships them to workers as assets.
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/material/material.h"
#include "common/scene/scene.h"

namespace lensfarm {

// A shape as read: world positions in double; normals, uvs and tangents (world space, not yet
// normalised after transforms) in mesh.normals / mesh.uv / mesh.tangents, indexed like positions;
// indices and materialIds set (materialIds index ImportedModel::materials, or the scene's
// materials for shapes the scene file writes inline).
struct MeshInput {
  TriangleMesh mesh;  // positions empty until the scene loader moves the shape to render space
  std::vector<DVec3> positions;
};

// Appends `from` to `to` and frees `from`'s memory; into an empty `to`, `from` is moved (nothing
// copied). Meshes are merged this way so that a big one is never held twice.
template <typename T>
void appendAndFree(std::vector<T>& to, std::vector<T>& from) {
  if (to.empty())
    to.swap(from);
  else
    to.insert(to.end(), from.begin(), from.end());
  std::vector<T>().swap(from);
}

// Reads a file that a model refers to by a path relative to the model file (a .bin buffer, a
// texture, a .mtl): its bytes, or nothing if there is no such file. The scene loader's reader
// resolves the path, records the file as an asset and hashes it.
using ModelFileReader = std::function<std::optional<std::string>(const std::string& relativePath)>;

// One use of a prototype: a node's world transform (model world space, before the scene's
// render-space move).
struct ModelInstance {
  uint32_t prototype;  // into ImportedModel::prototypes
  glm::dmat4 world;
  std::string name;
};

struct ImportedModel {
  std::vector<Material> materials;
  std::vector<MeshInput> meshes;
  // Meshes that several nodes use, in their own space (positions, normals and tangents not
  // transformed), and those uses: the scene loader makes them instances (scene/scene.h,
  // MeshInstance) or, for an emitting one, copies.
  std::vector<MeshInput> prototypes;
  std::vector<ModelInstance> instances;
  // The model's cameras as lensfarm "camera" objects (position, look_at, up, angle_of_view or
  // focal_length + sensor_width, ...), in the model's order; "name" holds the model's name and
  // "aspect_ratio" (if the model gives one) the aspect the author framed for.
  std::vector<nlohmann::json> cameras;
  // The model's lights as entries of a lensfarm "lights" array (point, spot, directional).
  std::vector<nlohmann::json> lights;
  // What the importer mapped approximately or ignored, for the user: "materials[2] "leaf":
  // alphaMode BLEND rendered as MASK with cutoff 0.5".
  std::vector<std::string> notes;
  // The model's bounds in world space (for a framing camera when it has none).
  DVec3 lo{std::numeric_limits<double>::max()}, hi{-std::numeric_limits<double>::max()};
};

}  // namespace lensfarm
