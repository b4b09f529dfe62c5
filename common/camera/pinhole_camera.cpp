#include "common/camera/pinhole_camera.h"

#include <algorithm>
#include <iterator>

namespace lensfarm {

void PinholeCamera::sampleRays(const CameraSampleLanes& s, CameraRayLanes& rays, float (&weight)[kPacketWidth]) const {
  lens_.generatePinholeRays(s.column, s.row, s.u0, s.u1, rays);
  std::fill(std::begin(weight), std::end(weight), lens_.aperture().weight());
}

}  // namespace lensfarm
