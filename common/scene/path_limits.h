#pragma once
// How long a path may be: the limits the integrators keep (render/integrator.h,
// render/volume_integrator.h) and the farm checks a worker's counters against (docs/farm.md,
// "Threat model"). Functions of the render settings alone.
#include <cstdint>

#include "common/scene/scene.h"

namespace lensfarm {

// The most segments (rays from a vertex or the lens) a path may have for the bounce limit B:
// B + 1 for the camera ray and the B counted bounces, as many again for mirror reflections that
// do not count, and never fewer than kMinPathSegmentLimit, so that B is honoured up to
// kMaxBounces (1024: 2050 segments) rather than cut at 255 bounces, and two facing mirrors still
// end. For B <= 127 the limit is 256, what it always was. The sampler gives every segment its
// own block of dimensions (dims::segment) with no upper end, so no other limit applies.
inline constexpr int kMinPathSegmentLimit = 256;
inline constexpr int pathSegmentLimit(int maxBounces) {
  return maxBounces + 1 > kMinPathSegmentLimit / 2 ? 2 * (maxBounces + 1) : kMinPathSegmentLimit;
}

// Index-matched boundaries one ray (or shadow ray) may cross before it is given up: a bound on
// the work of a degenerate scene (coincident interface layers), far above any real one.
inline constexpr int kMaxCrossings = 64;

// The number of segments a volume path may have: the surface tracer's limit plus room for the
// medium bounces and for crossings of index-matched boundaries.
int volumePathSegmentLimit(const RenderSettings& settings);

// The most rays one camera path of a unit may cast, the light paths traced beside it included,
// for any integrator: each of a volume path's segments (volumePathSegmentLimit) casts up to
// kMaxCrossings rays and as many for its shadow ray, and each of up to ratio + 1 light paths per
// camera path two rays per segment and one more. The coordinator refuses a worker's counters beyond it (docs/farm.md,
// "Threat model"); a fixed bound (1024) once refused honest units of B = 1000 with light sampling.
uint64_t maxRaysPerPath(const RenderSettings& settings);

}  // namespace lensfarm
