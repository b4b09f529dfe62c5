// libFuzzer target: the upload path. The input is a sequence of length-prefixed serialized
// UploadResultRequest pieces, fed to the assembler and then to a coordinator that holds a real
// lease, so a well-formed stream can reach the sensor. Every input must end accepted or refused
// with a FarmError, and the job's image must stay finite.
#include <cmath>
#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "coordinator.h"
#include "upload_assembler.h"
#include "util/error.h"
#include "util/version.h"

namespace {
struct Fixture {
  lensfarm::Coordinator coordinator;
  std::string job, worker;
  Fixture() {
    const std::string scene = R"({"format": "lensfarm-scene/1",
      "camera": {"type": "pinhole", "position": [0,0,-3], "look_at": [0,0,0], "sensor_width": 0.1, "focal_length": 0.1},
      "materials": {"w": {"type": "lambertian", "albedo": 0.5}},
      "shapes": [{"type": "quad", "corner": [-1,-1,0], "edge1": [0,2,0], "edge2": [2,0,0], "material": "w"}],
      "render": {"resolution": [2, 1], "samples_per_pixel": 1000000, "samples_per_unit": 1}})";
    job = coordinator.submit(lensfarm::JobSpec{"fuzz.json", scene, {}, {}, std::nullopt}, 0).id;
    worker = coordinator.registerWorker(
        lensfarm::WorkerInfo{"fuzz", 1, lensfarm::kProtocolVersion, lensfarm::kRendererVersion});
  }
};
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  spdlog::set_level(spdlog::level::off);  // refusals are expected by the thousand
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture fixture;
  lensfarm::Coordinator& c = fixture.coordinator;
  const auto grant = c.lease(fixture.worker, 0);  // a live lease the input may name (ids grow)
  lensfarm::UploadAssembler assembler;
  try {
    size_t offset = 0;
    while (offset + 2 <= size) {
      const size_t length = size_t(data[offset]) | (size_t(data[offset + 1]) << 8);
      offset += 2;
      if (length > size - offset) break;
      lensfarm::v1::UploadResultRequest piece;
      if (!piece.ParseFromArray(data + offset, int(length))) break;
      offset += length;
      assembler.add(piece);
    }
    lensfarm::UnitResult result = assembler.finish();
    if (grant && size > 0 && (data[0] & 1)) {  // sometimes aim at the real lease
      result.workerId = fixture.worker;
      result.leaseId = grant->leaseId;
      result.jobId = grant->jobId;
      result.unitIndex = grant->unit.index;
    }
    c.acceptResult(std::move(result));
  } catch (const lensfarm::FarmError&) {
  }
  for (float v : c.image(fixture.job).image.rgb)
    if (!std::isfinite(v)) std::abort();  // a refused upload touched the sensor
  return 0;
}
