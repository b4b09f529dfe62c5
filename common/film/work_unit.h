#pragma once
// A unit of work: a range of sample indices for every pixel of the frame (or of a tile). Units are
// the grain of progress and, in the farm, of scheduling: unit k covers samples
//     [k * samples_per_unit, min((k + 1) * samples_per_unit, samples_per_pixel)).
// Early units cover the whole frame, so the first snapshot already shows all of it. What a
// renderer fills (render/unit_renderer.h) and what the farm leases (farm/farm_types.h).
#include <cstdint>
#include <memory>

#include "common/film/sample_map.h"

namespace lensfarm {

// Cells [x, x + width) x [y, y + height) of the sensor (sensor orientation); width 0: the whole frame.
struct PixelRegion {
  int x = 0, y = 0, width = 0, height = 0;
  bool empty() const { return width <= 0 || height <= 0; }
  bool operator==(const PixelRegion& o) const { return x == o.x && y == o.y && width == o.width && height == o.height; }
};

struct WorkUnit {
  WorkUnit() = default;
  WorkUnit(uint64_t i, uint64_t first, uint32_t count) : index(i), firstSample(first), sampleCount(count) {}
  uint64_t index = 0;
  uint64_t firstSample = 0;
  uint32_t sampleCount = 0;
  // A tile unit (farm/job_layout.h): its cells, and the samples of one pass. The unit's samples
  // are traced pass by pass (each pass exactly a whole-frame unit's samples, so the same random
  // numbers) and each cell sums the passes with CompensatedSum from zero, returning its value():
  // the bits a Sensor holding the same passes develops. 0: one pass of sampleCount.
  PixelRegion region;
  uint32_t passSamples = 0;
  int64_t frame = 0;  // the scene frame (animation); 0 for a still
  // An adaptive unit (film/sample_map.h): each block of cells traces its own sample range, and
  // firstSample and sampleCount are not read. Whole-frame units only. Null: every cell traces
  // [firstSample, firstSample + sampleCount).
  std::shared_ptr<const SampleMap> samples;
  // The samples cell (i, j) traces: the map's count, else sampleCount; and its first: the map's
  // first position in the unit's half (SampleMap::sampleIndex gives its sample index), else
  // firstSample (a sample index).
  uint32_t countAt(int i, int j) const { return samples ? samples->countAt(i, j) : sampleCount; }
  uint64_t firstAt(int i, int j) const { return samples ? samples->firstAt(i, j) : firstSample; }
};

uint64_t unitCount(uint64_t samplesPerPixel, uint32_t samplesPerUnit);
WorkUnit unitAt(uint64_t index, uint64_t samplesPerPixel, uint32_t samplesPerUnit);

}  // namespace lensfarm
