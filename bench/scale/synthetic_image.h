#pragma once
// The known image of the scale test (bench/scale_bench.cpp): simulated workers
// do not render, they fill each leased unit with values computed from the unit
// alone, so the image a coordinator assembles is known exactly and any unit
// lost, counted twice or put in the wrong place shows.
//
// Sample s of cell (x, y) of scene frame f carries radiance h = b(x, y, f) +
// s^2 in every channel, b a hash of the cell and frame in [0, 64). A unit's
// cell holds the sum of h over its samples [first, first + count): count * b +
// (sum of s^2), an integer below 2^53, so exact in a double whatever the order
// of the sums. The final pixel is the mean over the job's S samples,
//   b + (S - 1)(2S - 1) / 6,
// exact in a float when S is a power of two and small (the scale jobs use S =
// 4). A pass unit summed twice moves the mean (its own mean of s^2 differs from
// the job's), a lost tile leaves its pixels unset, and a tile written elsewhere
// has the wrong b.
#include <cstdint>

#include "common/farm/farm_types.h"
#include "common/film/sensor.h"
#include "common/render/unit_renderer.h"

namespace lensfarm::scale {

// b(x, y, f) in [0, 64).
uint32_t cellBase(int x, int y, int64_t frame);

// Fills `result.buffer` with unit `unit`'s sums over its region (the whole
// width x height frame when the region is empty) and `result.stats` with the
// counters checkPlausible expects of it (one path per cell and sample, one ray
// per path).
void fillUnit(const WorkUnit& unit, int width, int height, UnitResult& result);

// The value cell (i, j) of scene frame `frame` must hold after all
// `samplesPerPixel` samples. Cells are in sensor orientation (film/sensor.h):
// image pixel (x, y) is cell (W-1-x, H-1-y).
double expectedCell(int i, int j, int64_t frame, uint64_t samplesPerPixel);

}  // namespace lensfarm::scale
