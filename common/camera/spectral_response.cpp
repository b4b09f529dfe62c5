// The sensor's spectral response (spectral_response.h).
#include "common/camera/spectral_response.h"

namespace lensfarm::spectral {

double response(int channel, double wavelengthNm) {
  const int band = bandOfChannel(channel);
  const double lo = kBandEdges[band], hi = kBandEdges[band + 1];
  return wavelengthNm >= lo && wavelengthNm < hi ? 1.0 / (hi - lo) : 0.0;
}

}  // namespace lensfarm::spectral
