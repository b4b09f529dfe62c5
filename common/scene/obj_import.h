#pragma once
// Wavefront OBJ with its MTL material libraries, read with tinyobjloader into an ImportedModel
// (scene/imported_model.h): positions (double), vertex normals, texture coordinates (v flipped to
// the glTF convention, texture/texture.h), groups and usemtl; MTL Kd/Ks/Ns/Ni/d/Tr/illum/Ke and
// map_Kd/map_Ks/map_Ns/map_d/map_bump/bump/norm/map_Ke mapped onto the principled material as
// the table in docs/scene-format.md, "OBJ and MTL", says.
//
// The whole file is one mesh, meshes[0], its triangles in file order. A file without normals
// and texture coordinates keeps OBJ's vertex numbering (positions in file order); otherwise each
// distinct (v, vt, vn) triple is one vertex. Triangles with no usemtl (or a usemtl naming no
// material of the libraries) have material kNoObjMaterial: the scene says what they are made of.
//
// Errors throw InputError naming the file and the line or element, never crash.
#include <cstdint>
#include <string>

#include "common/scene/imported_model.h"

namespace lensfarm {

inline constexpr uint32_t kNoObjMaterial = UINT32_MAX;

struct ImportedObj {
  ImportedModel model;
  // The group (OBJ "o" / "g" name, as tinyobjloader names shapes) of each triangle of
  // model.meshes[0], indexing groupNames, for the scene's group_materials.
  std::vector<std::string> groupNames;
  std::vector<uint32_t> triangleGroups;
};

// `text` is the OBJ file's content, `shown` its path for messages; mtllib files and textures are
// read through `read`, relative to it.
ImportedObj importObj(const std::string& text, const std::string& shown, const ModelFileReader& read);

// The same for text that checkObjText accepted, its ObjCheck::text, which is not checked again
// (the scene loader checks a file itself, to name the scene's field in its message). Taken by
// value: moved in, its memory is handed back as tinyobjloader reads it.
ImportedObj importCheckedObj(std::string checkedText, const std::string& shown, const ModelFileReader& read);

}  // namespace lensfarm
