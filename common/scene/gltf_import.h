#pragma once
// glTF 2.0 (.gltf with external or data-URI buffers and images, and .glb) read with tinygltf
// (libtinygltf-dev) into an ImportedModel (scene/imported_model.h). What is supported, mapped
// and ignored is the table in docs/scene-format.md, "glTF".
//
// Errors throw InputError naming the file and the element, e.g.
//   "model.glb: meshes[3].primitives[0]: accessor 12 reads past the end of buffer 2".
#include <string>

#include "common/scene/imported_model.h"

namespace lensfarm {

// `bytes` is the .gltf or .glb file's content, `shown` its path for messages; files it refers to
// are read through `read`, relative to it. (Taken by value: moved in, the bytes are freed as soon
// as tinygltf has read them, so a big model is not held three times over.)
ImportedModel importGltf(std::string bytes, const std::string& shown, const ModelFileReader& read);

}  // namespace lensfarm
