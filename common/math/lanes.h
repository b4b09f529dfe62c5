#pragma once
// Loops over the lanes of a packet (render/integrator.h): arrays over the kPacketWidth lanes
// (structure of arrays) and one formula applied to every lane, which the compiler turns into
// vector instructions.
//
// Such loops are compiled three times, for AVX-512, AVX2 and the x86-64 baseline, and the
// machine picks one when the program starts (GCC function multiversioning). Every version does
// the same IEEE operations on each lane in the same order (floating-point contraction is off
// for the whole project, CMakeLists.txt), so a lane's bits do not depend on the machine's vector
// width (tests/render/packet_integrator_test.cpp compares them with the one-ray tracer).
//
// A lane loop's body must stay free of calls and of branches the compiler cannot turn into
// selects; build with -fopt-info-vec to see which loops vectorise (docs/performance.md).

#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "common/math/vec.h"

namespace lensfarm {
// Rays travel in packets of up to 16 (render/integrator.h): Embree's 16-wide kernels trace them
// together, which is what AVX-512 machines are fastest at, and the lane loops work on 16 lanes.
inline constexpr int kPacketWidth = 16;

// A lane loop's view of an array of records (structs of 32-bit floats and integers, glm vectors
// among them) for reading one field of a different record in each lane. GCC vectorises such
// gathers of plain floats with 32-bit offsets, but not through glm's vector members (their
// unions keep the loop scalar) nor with 64-bit offsets, so fields are read as floats at their
// offsetof, and an array holds at most kMaxRecords records (its owner checks).
template <typename Record>
class GatherView {
  static_assert(std::is_standard_layout_v<Record> && sizeof(Record) % sizeof(float) == 0);
  static constexpr uint32_t kStride = sizeof(Record) / sizeof(float);

 public:
  static constexpr size_t kMaxRecords = UINT32_MAX / kStride;
  explicit GatherView(const Record* records) : floats_(reinterpret_cast<const float*>(records)) {}
  float f(uint32_t index, size_t offset) const { return floats_[index * kStride + uint32_t(offset / sizeof(float))]; }
  uint32_t u(uint32_t index, size_t offset) const { return std::bit_cast<uint32_t>(f(index, offset)); }
  Vec3 vec3(uint32_t index, size_t offset) const {
    return Vec3(f(index, offset), f(index, offset + sizeof(float)), f(index, offset + 2 * sizeof(float)));
  }

 private:
  const float* __restrict floats_;  // lane loops never write into the records they gather from
};
}  // namespace lensfarm

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define LENSFARM_LANE_LOOPS __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define LENSFARM_LANE_LOOPS
#endif
