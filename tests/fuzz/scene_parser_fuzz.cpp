// libFuzzer target: the scene parser. Any input must end in a scene or an InputError; anything
// else (a crash, another exception, a sanitizer report) is a finding. `make fuzz` runs it.
#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/scene/scene_loader.h"
#include "common/util/error.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  spdlog::set_level(spdlog::level::off);  // refusals are expected by the thousand
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // Any OBJ path the scene names resolves to a small valid mesh, so the fuzzer reaches past it.
  const lensfarm::AssetReader reader = [](const std::string& path) -> std::optional<std::string> {
    if (path.empty() || path[0] == 'x') return std::nullopt;
    return std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\ng top\nf 2 3 4\n");
  };
  try {
    lensfarm::Scene scene = lensfarm::parseScene(text, "fuzz.json", reader);
    (void)scene.camera();
  } catch (const lensfarm::InputError&) {
  }
  return 0;
}
