#include "common/film/sample_map.h"

#include <algorithm>

namespace lensfarm {

uint64_t SampleMap::totalSamples(int width, int height) const {
  uint64_t total = 0;
  for (int by = 0; by < blocksY; ++by)
    for (int bx = 0; bx < blocksX; ++bx) {
      const uint64_t w = uint64_t(std::min(blockEdge, width - bx * blockEdge));
      const uint64_t h = uint64_t(std::min(blockEdge, height - by * blockEdge));
      total += w * h * count[size_t(by) * size_t(blocksX) + size_t(bx)];
    }
  return total;
}

uint32_t SampleMap::maxCount() const { return count.empty() ? 0 : *std::max_element(count.begin(), count.end()); }

std::string SampleMap::whyNotFor(int width, int height) const {
  if (passSamples < 1 || half > 1)
    return "pass of " + std::to_string(passSamples) + " samples, half " + std::to_string(half) +
           " (a pass of at least 1, half 0 or 1)";
  if (blockEdge < 1) return "block edge " + std::to_string(blockEdge) + " is not at least 1";
  if (blocksX != blocksAlong(width, blockEdge) || blocksY != blocksAlong(height, blockEdge))
    return std::to_string(blocksX) + " x " + std::to_string(blocksY) + " blocks of " + std::to_string(blockEdge) +
           " do not cover a " + std::to_string(width) + " x " + std::to_string(height) + " frame";
  const size_t blocks = size_t(blocksX) * size_t(blocksY);
  if (first.size() != blocks || count.size() != blocks)
    return std::to_string(first.size()) + " first samples and " + std::to_string(count.size()) + " counts for " +
           std::to_string(blocks) + " blocks";
  for (size_t b = 0; b < blocks; ++b)
    if (count[b] > (1u << 31) || first[b] > (uint64_t(1) << 60) / passSamples)
      return "block " + std::to_string(b) + " asks for samples [" + std::to_string(first[b]) + ", +" +
             std::to_string(count[b]) + ")";
  return "";
}

}  // namespace lensfarm
