#include "common/scene/path_limits.h"

#include <cmath>

namespace lensfarm {

int volumePathSegmentLimit(const RenderSettings& settings) {
  return pathSegmentLimit(settings.maxBounces) + settings.maxMediumBounces + kMaxCrossings;
}

uint64_t maxRaysPerPath(const RenderSettings& settings) {
  const uint64_t camera = uint64_t(volumePathSegmentLimit(settings)) * 2 * uint64_t(kMaxCrossings);
  // Per light path: each segment's ray and its vertex's camera connection, and the check of an
  // infinite light's particle back to the light (render/light_emission.h); up to ratio + 1 light
  // paths per camera path (render/light_tracer.h, lightPathsOf rounds up per unit).
  const uint64_t perLightPath = uint64_t(pathSegmentLimit(settings.maxBounces)) * 2 + 1;
  const uint64_t lightPaths = uint64_t(std::ceil(settings.lightTracingRatio)) + 1;
  return camera + lightPaths * perLightPath;
}

}  // namespace lensfarm
