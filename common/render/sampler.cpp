#include "common/render/sampler.h"

namespace lensfarm {

namespace {
LENSFARM_LANE_LOOPS void independentValues(const uint64_t* __restrict keys, uint32_t dimension,
                                           float* __restrict values) {
  for (int k = 0; k < kPacketWidth; ++k) values[k] = SampleStream::independentValue(keys[k], dimension);
}

LENSFARM_LANE_LOOPS void sobolFirstValues(const uint64_t* __restrict pixelKeys, const uint32_t* __restrict indices,
                                          uint32_t dimension, float* __restrict values) {
  for (int k = 0; k < kPacketWidth; ++k) values[k] = SampleStream::sobolFirst(pixelKeys[k], indices[k], dimension);
}

LENSFARM_LANE_LOOPS void sobolPairs(const uint64_t* __restrict pixelKeys, const uint32_t* __restrict indices,
                                    uint32_t dimension, float* __restrict x, float* __restrict y) {
  for (int k = 0; k < kPacketWidth; ++k) {
    const Vec2 v = SampleStream::sobolPair(pixelKeys[k], indices[k], dimension);
    x[k] = v.x, y[k] = v.y;
  }
}
}  // namespace

void SampleStream::lanes1D(const LaneKeys& keys, uint32_t dimension, float (&values)[kPacketWidth]) {
  if (dimension >= kStratifiedDimensions)
    independentValues(keys.key, dimension, values);
  else
    sobolFirstValues(keys.pixelKey, keys.index, dimension, values);
}

void SampleStream::lanes2D(const LaneKeys& keys, uint32_t dimension, float (&x)[kPacketWidth],
                           float (&y)[kPacketWidth]) {
  if (dimension >= kStratifiedDimensions) {
    independentValues(keys.key, dimension, x);
    independentValues(keys.key, dimension + 1, y);
  } else {
    sobolPairs(keys.pixelKey, keys.index, dimension, x, y);
  }
}

}  // namespace lensfarm
