#pragma once
// From linear radiance to a viewable 8-bit sRGB picture.
//
// Automatic exposure (seed §4.7.4): every pixel is divided by the average per-cell intensity,
// so the image is never over- or under-exposed however long it rendered. Intensity here is
// luminance (Rec. 709). Then the EV compensation (x 2^EV), a tone map (clamp, or Reinhard
// x / (1 + x) per channel), and the sRGB transfer function.
#include <cstdint>
#include <vector>

#include "film/sensor.h"
#include "scene/scene.h"

namespace lensfarm {

// The factor that maps the image's mean luminance to 1 (1 for a black image).
double autoExposureScale(const Image& image);

// 8-bit sRGB, 3 bytes per pixel, row 0 at the top.
std::vector<uint8_t> exposeToSrgb8(const Image& image, const ExposureSettings& settings);

// The sRGB opto-electronic transfer function, for x in [0, 1].
float linearToSrgb(float x);

}  // namespace lensfarm
