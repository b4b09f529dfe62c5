#include "common/scene/path_limits.h"

namespace lensfarm {

int volumePathSegmentLimit(const RenderSettings& settings) {
  return pathSegmentLimit(settings.maxBounces) + settings.maxMediumBounces + kMaxCrossings;
}

uint64_t maxRaysPerPath(const RenderSettings& settings) {
  const uint64_t camera = uint64_t(volumePathSegmentLimit(settings)) * 2 * uint64_t(kMaxCrossings);
  const uint64_t light = uint64_t(pathSegmentLimit(settings.maxBounces)) * 2;
  return camera + light;
}

}  // namespace lensfarm
