#pragma once
// Which samples an adaptive unit traces in each cell (docs/accuracy.md, "Adaptive sampling").
//
// The frame is cut into square blocks of `blockEdge` cells (edge blocks smaller). A job's samples
// per pixel fall in two halves, as its units do (film/convergence.h): sample index s belongs to
// half (s / P) & 1, P the job's pass size (render/sampler.h keys the Sobol sampler's two
// replicates the same way), and the half's t-th sample is
//     s = (t / P) * 2P + half * P + t % P.
// An adaptive unit is in one half (its index's parity); every cell of block b traces positions
// [first[b], first[b] + count[b]) of that half's sequence. Random numbers are keyed by (pixel,
// sample index, dimension), so a sample is the same bits whichever unit traces it, and no sample
// is traced twice as long as each block's positions follow one another in each half
// (film/adaptive_allocation.h makes them so). A block of count 0 is not traced.
//
// Cells are sensor cells (sensor orientation, as PixelRegion), blocks row-major.
#include <cstdint>
#include <string>
#include <vector>

namespace lensfarm {

struct SampleMap {
  uint32_t passSamples = 1;  // P
  uint32_t half = 0;         // 0 or 1
  int blockEdge = 0;
  int blocksX = 0, blocksY = 0;
  std::vector<uint64_t> first;  // per block
  std::vector<uint32_t> count;  // per block: samples of each of its cells

  // Blocks of edge `blockEdge` over a width x height frame.
  static int blocksAlong(int cells, int blockEdge) { return (cells + blockEdge - 1) / blockEdge; }
  size_t blockOf(int i, int j) const { return size_t(j / blockEdge) * size_t(blocksX) + size_t(i / blockEdge); }
  uint32_t countAt(int i, int j) const { return count[blockOf(i, j)]; }
  uint64_t firstAt(int i, int j) const { return first[blockOf(i, j)]; }
  // The sample index of position t of the unit's half.
  uint64_t sampleIndex(uint64_t t) const {
    return (t / passSamples) * 2 * passSamples + half * passSamples + t % passSamples;
  }
  // Samples of every cell of a width x height frame (the unit's paths).
  uint64_t totalSamples(int width, int height) const;
  uint32_t maxCount() const;
  // Empty if the map fits a width x height frame (blocks cover it exactly, a pass of at least 1, a
  // half of 0 or 1, counts at most 2^31, first positions at most 2^60 / P, so that every sample
  // index stays below 2^62), else what is wrong: for a map from the network.
  std::string whyNotFor(int width, int height) const;
};

}  // namespace lensfarm
