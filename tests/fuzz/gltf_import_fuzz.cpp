// libFuzzer target: the glTF importer (.gltf and .glb bytes alike, recognised by their magic). Any
// input must end in a model or an InputError; anything else (a crash, another exception, a
// sanitizer report) is a finding. `make fuzz` runs it. The reader finds no file, so external
// buffers and images are refused; data: URIs and a .glb's BIN chunk are read.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "common/scene/gltf_import.h"
#include "common/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const lensfarm::ModelFileReader reader = [](const std::string&) -> std::optional<std::string> {
    return std::nullopt;
  };
  try {
    const lensfarm::ImportedModel model = lensfarm::importGltf(bytes, "fuzz.gltf", reader);
    (void)model;
  } catch (const lensfarm::InputError&) {
  }
  return 0;
}
