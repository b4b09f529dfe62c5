#pragma once
// Image textures: an RGBA image in linear values with its mip-map pyramid, sampled bilinearly
// within a level and linearly between levels (trilinear), with glTF's wrap modes.
//
// Conventions (written once; docs/scene-format.md, "Textures", repeats them for scene authors):
//  - Texture coordinates are glTF's: (0, 0) is the top-left corner of the image (its first row),
//    u grows to the right and v downwards; texel (i, j) covers [i, i + 1] x [j, j + 1] / size and
//    its value sits at its centre. OBJ's vt has v growing upwards: the OBJ reader stores 1 - v.
//  - Values are linear. 8- and 16-bit images in a colour role (base colour, emission) are decoded
//    from sRGB when they are loaded (texture/image_decode.h); data roles (roughness, metallic,
//    normals, alpha) and float images (EXR, HDR) are taken as they are.
//  - Filtering: the pyramid halves each side per level with an area-weighted box (an odd side's
//    texels are shared between the two halves they straddle, so every level keeps the mean). A
//    lookup takes a footprint, the width in texture space that one pixel of the image covers there;
//    the level is log2(footprint * max(width, height)), so a minified texture is averaged rather
//    than aliased. The renderer estimates the footprint without ray differentials, from the
//    distance to the camera as pbrt-v4 does for secondary hits (render/shading_point.h).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/math/vec.h"

namespace lensfarm {

using Vec4 = glm::vec4;

// An image of 4 float channels per texel (RGBA), row-major, row 0 at the top.
struct RgbaImage {
  int width = 0, height = 0;
  std::vector<float> texels;  // 4 per texel

  Vec4 at(int x, int y) const {
    const size_t k = 4 * (size_t(y) * size_t(width) + size_t(x));
    return Vec4(texels[k], texels[k + 1], texels[k + 2], texels[k + 3]);
  }
};

// glTF sampler wrap modes (glTF 2.0 §5.26): what coordinates outside [0, 1] read.
enum class Wrap { kRepeat, kMirroredRepeat, kClampToEdge };

// What a lookup filters with. kNearest: the texel under the point at the finest level (glTF
// magFilter NEAREST, e.g. pixel art); kLinear: trilinear as above.
enum class TextureFilter { kLinear, kNearest };

class Texture {
 public:
  // `name` is what errors and summaries call it ("model.glb: images[2]" or a file path).
  Texture(std::string name, RgbaImage image, Wrap wrapS = Wrap::kRepeat, Wrap wrapT = Wrap::kRepeat,
          TextureFilter filter = TextureFilter::kLinear);

  // The filtered value at `uv` for a footprint of `width` in texture space (0: the finest level).
  Vec4 sample(Vec2 uv, float width = 0.0f) const;
  // The bilinear value at `uv` in pyramid level `level` (0 = the image itself).
  Vec4 bilinear(Vec2 uv, int level) const;

  const std::string& name() const { return name_; }
  int width() const { return levels_.front().width; }
  int height() const { return levels_.front().height; }
  int levels() const { return int(levels_.size()); }
  const RgbaImage& level(int k) const { return levels_[size_t(k)]; }
  // Bytes held (every level), for memory estimates.
  size_t bytes() const;

 private:
  std::string name_;
  std::vector<RgbaImage> levels_;
  Wrap wrapS_, wrapT_;
  TextureFilter filter_;
};

// KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv, rotation in radians
// counter-clockwise as the extension defines it (its matrix, applied to (u, v, 1)).
struct TextureTransform {
  Vec2 offset{0.0f}, scale{1.0f};
  float rotation = 0.0f;
  bool identity() const { return offset == Vec2(0.0f) && scale == Vec2(1.0f) && rotation == 0.0f; }
  Vec2 apply(Vec2 uv) const;
};

// A texture as a material uses it: which coordinate set (TEXCOORD_n) and the transform on it.
struct TextureRef {
  std::shared_ptr<const Texture> texture;  // null: no texture in this slot
  int uvSet = 0;                           // 0 or 1
  TextureTransform transform;

  explicit operator bool() const { return texture != nullptr; }
  Vec2 coordinates(const Vec2 (&uv)[2]) const { return transform.apply(uv[uvSet]); }
  // The lookup at a point with texture coordinates uv (both sets) and footprint `width`.
  Vec4 sample(const Vec2 (&uv)[2], float width) const {
    return texture->sample(coordinates(uv), width * std::max(std::abs(transform.scale.x), std::abs(transform.scale.y)));
  }
};

}  // namespace lensfarm
