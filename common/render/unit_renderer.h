#pragma once
// Rendering a unit of work (film/work_unit.h): renderUnit traces a unit on all threads of the calling TBB arena. Each
// pixel is owned by one task and sums its samples in sample order, so the buffer is bitwise the same for any thread
// count, and no lock is taken on the hot path.
#include <atomic>
#include <cstdint>
#include <memory>

#include "common/film/sensor.h"
#include "common/film/work_unit.h"
#include "common/render/integrator.h"
#include "common/render/render_scene.h"
#include "common/scene/path_limits.h"

namespace lensfarm {

// How rays are cast: as 16-wide packets (always, in production), or one at a time with the
// reference tracer (benchmarks measure what packets gain; tests check both give the same bits).
enum class RayGrouping { kPackets, kSingleRays };

// Fills `out` (resized to the unit's region: the frame, or its tile) with the unit's sums and per-cell sample counts
// and adds to `stats`. Returns false, with `out` incomplete, if `cancel` was raised before it finished.
bool renderUnit(const RenderScene& rs, const WorkUnit& unit, SensorBuffer& out, PathStats& stats,
                const std::atomic<bool>* cancel = nullptr, RayGrouping grouping = RayGrouping::kPackets);

}  // namespace lensfarm
