#pragma once
// Adaptive sampling: where the next round of samples goes (docs/accuracy.md, "Adaptive sampling").
//
// An adaptive job (farm/job_layout.h) first renders uniform passes, then rounds of adaptive units.
// At the start of each round the film holds exactly the units before it (the coordinator sums
// units in order), and this allocation is a function of that film alone: the same bits whatever
// the worker count, order of arrival or restarts. Each of the round's units gives every cell of
// block b the same m_b samples, half of the units in each half-image, so the two halves stay
// balanced cell by cell and the live error estimate (film/convergence.h) stays valid.
//
// The rule is Neyman's allocation (J. Neyman 1934, "On the two different aspects of the
// representative method"): the image's mean squared error, sum over cells of s_b^2 / N_b, with a
// fixed total of samples is least when N_b, the final samples of a cell of block b, is
// proportional to s_b, the per-sample standard deviation there. s_b^2 is the mean over the block's
// cells and RGB of ConvergenceTracker::cellVariance (the halves' difference: no reference). The
// round tops each block up towards lambda * s_b, lambda set so that the round spends its budget,
// with a floor (every block gets at least `floor` of the mean, so no region starves on an early
// estimate of zero: a light path not found yet) and a cap (16x the mean: an estimate that is
// noise itself cannot take the round). Blocks pool hundreds of cells' estimates, so one pixel's
// lucky sample barely moves its own count: the selection bias of reusing the samples is far below
// the noise (measured in docs/accuracy.md).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/film/convergence.h"
#include "common/film/sample_map.h"
#include "common/film/sensor.h"

namespace lensfarm {

struct RoundAllocation {
  uint64_t start = 0;  // the round's units are [start, start + units)
  uint32_t units = 0;  // even
  // Per block: first = positions of each half the film holds (a cell's samples / 2, the same in
  // every cell of a block), count = the samples each unit of the round gives its cells.
  SampleMap base;

  // Unit u's map (start <= u < start + units): in half u & 1, the (u - start) / 2-th of the
  // round's units in that half.
  std::shared_ptr<const SampleMap> mapOf(uint64_t u) const;
  // Samples a unit of the round traces over a width x height frame.
  uint64_t unitSamples(int width, int height) const { return base.totalSamples(width, height); }

  // Exact bytes, for checkpoints; deserialize throws std::runtime_error on bytes that are not one.
  std::string serialize() const;
  static RoundAllocation deserialize(const std::string& bytes);
};

struct AllocationRequest {
  uint64_t start = 0;
  uint32_t units = 0;        // the round's units (even)
  uint32_t passSamples = 1;  // P: a unit's mean samples per cell
  int blockEdge = 16;
  double floor = 0.125;  // a block's least samples per unit, as a fraction of P (at least 1 sample)
};
inline constexpr double kAllocationCap = 16.0;  // a block's most samples per unit, in units of P

// The round `request` describes for `film` (holding every unit before request.start) and its
// halves. Every cell of the film must hold the same count in each half (true of every film an
// adaptive layout makes); throws std::invalid_argument otherwise.
RoundAllocation allocateRound(const Sensor& film, const ConvergenceTracker& halves, const AllocationRequest& request);

}  // namespace lensfarm
