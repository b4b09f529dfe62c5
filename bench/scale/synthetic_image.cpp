#include "bench/scale/synthetic_image.h"

#include <algorithm>

namespace lensfarm::scale {
namespace {

// Sum of s^2 for s in [0, n): n (n - 1) (2n - 1) / 6.
double sumOfSquaresBelow(uint64_t n) { return n == 0 ? 0.0 : double(n) * double(n - 1) * double(2 * n - 1) / 6.0; }

}  // namespace

uint32_t cellBase(int x, int y, int64_t frame) {
  // SplitMix64's finaliser (Steele et al. 2014) over the packed coordinates.
  uint64_t z = (uint64_t(uint32_t(x)) << 40) ^ (uint64_t(uint32_t(y)) << 16) ^ uint64_t(frame) * 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return uint32_t((z ^ (z >> 31)) & 63u);
}

void fillUnit(const WorkUnit& unit, int width, int height, UnitResult& result) {
  PixelRegion region = unit.region;
  if (region.empty()) region = PixelRegion{0, 0, width, height};
  SensorBuffer& buffer = result.buffer;
  if (buffer.width != region.width || buffer.height != region.height)
    buffer = SensorBuffer(region.width, region.height);
  const double count = double(unit.sampleCount);
  const double squares = sumOfSquaresBelow(unit.firstSample + unit.sampleCount) - sumOfSquaresBelow(unit.firstSample);
  for (int j = 0; j < region.height; ++j)
    for (int i = 0; i < region.width; ++i) {
      const size_t cell = size_t(j) * size_t(region.width) + size_t(i);
      const double sum = count * double(cellBase(region.x + i, region.y + j, unit.frame)) + squares;
      std::fill_n(buffer.sums.begin() + std::ptrdiff_t(3 * cell), 3, sum);
    }
  std::fill(buffer.samples.begin(), buffer.samples.end(), unit.sampleCount);
  result.stats = PathStats{};
  result.stats.paths = uint64_t(region.width) * uint64_t(region.height) * unit.sampleCount;
  result.stats.rays = result.stats.paths;
}

double expectedCell(int x, int y, int64_t frame, uint64_t samplesPerPixel) {
  return double(cellBase(x, y, frame)) + sumOfSquaresBelow(samplesPerPixel) / double(samplesPerPixel);
}

}  // namespace lensfarm::scale
