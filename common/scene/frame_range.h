#pragma once
// A range of animation frames: first, first + step, ... up to last (inclusive).
#include <cstdint>

namespace lensfarm {

inline constexpr uint64_t kMaxFrames = 1000000;  // frames in one job

struct FrameRange {
  int64_t first = 1, last = 1, step = 1;
  uint64_t count() const { return last < first || step < 1 ? 0 : uint64_t((last - first) / step) + 1; }
  int64_t frameAt(uint64_t i) const { return first + int64_t(i) * step; }
};

}  // namespace lensfarm
