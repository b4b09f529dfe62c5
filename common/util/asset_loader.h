#pragma once
// How a part of the scene parser reads a file the scene names (an environment map, a VDB grid).
#include <functional>
#include <string>

namespace lensfarm {

class FieldReader;

// A file a scene names, read by the scene loader (through its asset reader, so that the file is
// hashed and shipped to workers like an OBJ): `shown` is its path for messages.
struct LoadedAsset {
  std::string shown;
  std::string bytes;
};
// Reads the file named by field `key` of r, or fails naming the field and the path; `kind` says
// what it is for ("environment map").
using AssetLoader = std::function<LoadedAsset(FieldReader& r, const std::string& key, const std::string& kind)>;

}  // namespace lensfarm
