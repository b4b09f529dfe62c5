#pragma once
// Decodes image files for textures: PNG, JPEG (stb_image, libstb-dev), Radiance HDR (stb_image)
// and OpenEXR (the OpenEXR library), recognised by their bytes, not their names.
//
// 8- and 16-bit images are scaled to [0, 1] and, for ColorEncoding::kSrgb, decoded with the sRGB
// transfer function (IEC 61966-2-1) to linear values; alpha is always linear. Float images (EXR,
// HDR) are linear whatever the encoding says. Grey images fill RGB with the grey value; images
// without alpha get alpha 1.
//
// Any problem (unknown format, truncated data, a size beyond kMaxTextureSide, a non-finite value
// in a float image) throws InputError naming `name`, e.g.
//   "model.glb: images[3]: not a PNG, JPEG, HDR or EXR image (starts with 47 49 46 38)".
#include <string>

#include "common/texture/texture.h"

namespace lensfarm {

enum class ColorEncoding { kSrgb, kLinear };

inline constexpr int kMaxTextureSide = 32768;

RgbaImage decodeImage(const std::string& bytes, const std::string& name, ColorEncoding encoding);

// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value in [0, 1] to linear.
float srgbToLinear(float encoded);

}  // namespace lensfarm
