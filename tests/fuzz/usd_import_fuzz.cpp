// libFuzzer target: the USD reader (scene/usda_parser.h, scene/usd_stage.h, scene/usd_import.h).
// Any input must end in a model or an InputError; anything else (a crash, another exception, a
// sanitizer report, a hang) is a finding. `make fuzz` runs it from the shipped USD scenes. The
// reader serves one more layer, "other.usda", as the fuzzer's own input again, so references,
// sublayers and their cycles are explored too.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "common/scene/usd_import.h"
#include "common/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const lensfarm::ModelFileReader reader = [&](const std::string& path) -> std::optional<std::string> {
    if (path == "other.usda") return bytes;
    return std::nullopt;
  };
  try {
    const lensfarm::ImportedModel model = lensfarm::importUsd(bytes, "fuzz.usda", reader);
    (void)model;
  } catch (const lensfarm::InputError&) {
  }
  return 0;
}
