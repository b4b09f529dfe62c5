// libFuzzer target: the upload path. The input is a sequence of length-prefixed serialized
// UploadResultRequest pieces, fed to the assembler and then to a coordinator that holds a real
// lease, so a well-formed stream can reach the sensor. Every input must end accepted or refused
// with a FarmError, and the job's image must stay finite.
//
// Inputs whose first byte has bit 1 set are compressed uploads instead (SUMS_ENCODING_SHUFFLE_ZSTD):
// random bytes are almost never a zstd frame, so the input describes pieces that are real encoded
// blocks (farm/sums_codec.h) of doubles taken from the input, then spoiled as the input says (a
// byte changed, cut short, a byte appended, a wrong offset), so the decoder meets near-valid frames.
#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>
#include <cmath>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "common/farm/sums_codec.h"
#include "common/util/error.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/upload_assembler.h"

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

// The compressed stream an input describes: a header for the fixture's 2 x 1 frame (6 doubles), then
// per piece 3 bytes (the count of doubles, 0-7; how to spoil the block; where) and 8 bytes per double.
void addCompressedPieces(const uint8_t* data, size_t size, lensfarm::UploadAssembler& assembler) {
  lensfarm::v1::UploadResultRequest first;
  first.mutable_header()->set_width(2);
  first.mutable_header()->set_height(1);
  first.mutable_header()->set_encoding(lensfarm::v1::SUMS_ENCODING_SHUFFLE_ZSTD);
  first.mutable_header()->mutable_stats()->set_paths(2);
  assembler.add(first);
  uint64_t offset = 0;
  size_t at = 1;
  while (at + 3 <= size) {
    const size_t count = data[at] & 7;
    const uint8_t spoil = data[at + 1], where = data[at + 2];
    at += 3;
    if (count * 8 > size - at) break;
    std::vector<double> values(count);
    if (count > 0) std::memcpy(values.data(), data + at, count * 8);  // memcpy from null is undefined, even of 0 bytes
    at += count * 8;
    std::string block = lensfarm::encodeSumsBlock(values.data(), count);
    switch (spoil & 3) {
      case 1: block[where % block.size()] = char(block[where % block.size()] ^ (spoil | 1)); break;
      case 2: block.resize(where % block.size()); break;
      case 3: block.push_back(char(where)); break;
      default: break;
    }
    lensfarm::v1::UploadResultRequest piece;
    piece.set_offset(spoil & 4 ? where : offset);
    piece.set_sums(block);
    assembler.add(piece);
    offset += count;
  }
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture fixture;
  lensfarm::Coordinator& c = fixture.coordinator;
  const auto grant = c.lease(fixture.worker, 0);  // a live lease the input may name (ids grow)
  lensfarm::UploadAssembler assembler;
  try {
    const bool compressed = size > 0 && (data[0] & 2);
    if (compressed) addCompressedPieces(data, size, assembler);
    size_t offset = 0;
    while (!compressed && offset + 2 <= size) {
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
