#include "common/film/work_unit.h"

#include <algorithm>

namespace lensfarm {

uint64_t unitCount(uint64_t samplesPerPixel, uint32_t samplesPerUnit) {
  return (samplesPerPixel + samplesPerUnit - 1) / samplesPerUnit;
}

WorkUnit unitAt(uint64_t index, uint64_t samplesPerPixel, uint32_t samplesPerUnit) {
  const uint64_t first = index * samplesPerUnit;
  const uint64_t count = std::min<uint64_t>(samplesPerUnit, samplesPerPixel - std::min(first, samplesPerPixel));
  WorkUnit unit;
  unit.index = index;
  unit.firstSample = first;
  unit.sampleCount = uint32_t(count);
  return unit;
}

}  // namespace lensfarm
