#pragma once
// Counter-based random numbers: every value is a pure function of
//     (job seed, pixel, sample index, dimension),
// so a sample traces the same path on any worker, thread count or retry (design.md invariant).
// The hash is two rounds of the SplitMix64 finaliser over a key that mixes the four counters;
// each call costs a few multiplies and holds no state between pixels.
#include <cstdint>

#include "math/vec.h"

namespace lensfarm {

// Dimension layout of one camera path. Each path segment owns a fixed block of dimensions, so
// adding a lobe or a light never shifts the numbers of another segment.
namespace dims {
inline constexpr uint32_t kSensor = 0;  // 2D: point in the sensor cell
inline constexpr uint32_t kLens = 2;    // 2D: point on the lens disk
inline constexpr uint32_t kFirstSegment = 4;
inline constexpr uint32_t kPerSegment = 8;
inline constexpr uint32_t kLightChoice = 0;    // 1D, within a segment block
inline constexpr uint32_t kLightPoint = 1;     // 2D
inline constexpr uint32_t kMaterial = 3;       // 2D
inline constexpr uint32_t segment(uint32_t s) { return kFirstSegment + s * kPerSegment; }
}  // namespace dims

class SampleStream {
 public:
  SampleStream(uint64_t seed, uint64_t pixel, uint64_t sampleIndex)
      : key_(mix(mix(mix(seed ^ 0x6a09e667f3bcc909ull) ^ pixel) ^ (sampleIndex * 0x9e3779b97f4a7c15ull))) {}

  // A float in [0, 1).
  float get1D(uint32_t dimension) const {
    const uint64_t h = mix(key_ ^ (uint64_t(dimension) * 0xd1b54a32d192ed03ull + 0x8cb92ba72f3d8dd7ull));
    return float(h >> 40) * 0x1.0p-24f;
  }
  Vec2 get2D(uint32_t dimension) const { return Vec2(get1D(dimension), get1D(dimension + 1)); }

  static uint64_t mix(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

 private:
  uint64_t key_;
};

}  // namespace lensfarm
