#include "render/sampler.h"

namespace lensfarm {

namespace {
LENSFARM_LANE_LOOPS void independentValues(const uint64_t* __restrict keys, uint32_t dimension, float* __restrict values) {
  for (int k = 0; k < kPacketWidth; ++k) values[k] = SampleStream::independentValue(keys[k], dimension);
}
}  // namespace

void SampleStream::independentLanes(const LaneKeys& keys, uint32_t dimension, float (&values)[kPacketWidth]) {
  independentValues(keys.key, dimension, values);
}

}  // namespace lensfarm
