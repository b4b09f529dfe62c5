#include "texture/texture.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace lensfarm {

namespace {
// The next level of the pyramid: each texel the mean of the 2x2 texels it covers (a side of 1
// stays 1; an odd side's last texel is averaged with itself).
RgbaImage halve(const RgbaImage& in) {
  RgbaImage out;
  out.width = std::max(1, in.width / 2);
  out.height = std::max(1, in.height / 2);
  out.texels.resize(4 * size_t(out.width) * size_t(out.height));
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const int x0 = std::min(2 * x, in.width - 1), x1 = std::min(2 * x + 1, in.width - 1);
      const int y0 = std::min(2 * y, in.height - 1), y1 = std::min(2 * y + 1, in.height - 1);
      const Vec4 mean = 0.25f * (in.at(x0, y0) + in.at(x1, y0) + in.at(x0, y1) + in.at(x1, y1));
      const size_t k = 4 * (size_t(y) * size_t(out.width) + size_t(x));
      for (int c = 0; c < 4; ++c) out.texels[k + size_t(c)] = mean[c];
    }
  return out;
}

// A texel index wrapped into [0, size) by glTF's rule.
int wrapIndex(int i, int size, Wrap wrap) {
  switch (wrap) {
    case Wrap::kClampToEdge:
      return std::clamp(i, 0, size - 1);
    case Wrap::kMirroredRepeat: {
      const int period = 2 * size;
      int m = i % period;
      if (m < 0) m += period;
      return m < size ? m : period - 1 - m;
    }
    case Wrap::kRepeat:
    default: {
      int m = i % size;
      return m < 0 ? m + size : m;
    }
  }
}

// Texture coordinates far outside [0, 1] (a tiling of 1e9) keep their fractional position:
// reduced to one period of the wrap before they are scaled to texels, so float keeps the detail.
float reduce(float u, Wrap wrap) {
  if (!std::isfinite(u)) return 0.0f;
  if (wrap == Wrap::kClampToEdge) return std::clamp(u, -1.0f, 2.0f);
  const float period = wrap == Wrap::kRepeat ? 1.0f : 2.0f;
  return u - period * std::floor(u / period);
}
}  // namespace

Texture::Texture(std::string name, RgbaImage image, Wrap wrapS, Wrap wrapT, TextureFilter filter)
    : name_(std::move(name)), wrapS_(wrapS), wrapT_(wrapT), filter_(filter) {
  levels_.push_back(std::move(image));
  while (levels_.back().width > 1 || levels_.back().height > 1) levels_.push_back(halve(levels_.back()));
}

size_t Texture::bytes() const {
  size_t total = 0;
  for (const RgbaImage& level : levels_) total += level.texels.size() * sizeof(float);
  return total;
}

Vec4 Texture::bilinear(Vec2 uv, int level) const {
  const RgbaImage& img = levels_[size_t(std::clamp(level, 0, levels() - 1))];
  const float x = reduce(uv.x, wrapS_) * float(img.width) - 0.5f;
  const float y = reduce(uv.y, wrapT_) * float(img.height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const int x0 = int(fx), y0 = int(fy);
  const float ax = x - fx, ay = y - fy;
  const int xa = wrapIndex(x0, img.width, wrapS_), xb = wrapIndex(x0 + 1, img.width, wrapS_);
  const int ya = wrapIndex(y0, img.height, wrapT_), yb = wrapIndex(y0 + 1, img.height, wrapT_);
  return (1.0f - ay) * ((1.0f - ax) * img.at(xa, ya) + ax * img.at(xb, ya)) +
         ay * ((1.0f - ax) * img.at(xa, yb) + ax * img.at(xb, yb));
}

Vec4 Texture::sample(Vec2 uv, float width) const {
  if (filter_ == TextureFilter::kNearest) {
    const RgbaImage& img = levels_.front();
    const int x = wrapIndex(int(std::floor(reduce(uv.x, wrapS_) * float(img.width))), img.width, wrapS_);
    const int y = wrapIndex(int(std::floor(reduce(uv.y, wrapT_) * float(img.height))), img.height, wrapT_);
    return img.at(x, y);
  }
  // The level whose texels are as wide as the footprint (Williams 1983, "Pyramidal Parametrics").
  const float texels = width * float(std::max(levels_.front().width, levels_.front().height));
  if (!(texels > 1.0f)) return bilinear(uv, 0);
  const float level = std::min(std::log2(texels), float(levels() - 1));
  const int lo = int(std::floor(level));
  const float t = level - float(lo);
  if (t == 0.0f || lo + 1 >= levels()) return bilinear(uv, lo);
  return (1.0f - t) * bilinear(uv, lo) + t * bilinear(uv, lo + 1);
}

Vec2 TextureTransform::apply(Vec2 uv) const {
  if (identity()) return uv;
  // KHR_texture_transform's matrix T * R * S with R = [[cos, sin], [-sin, cos]].
  const float c = std::cos(rotation), s = std::sin(rotation);
  const Vec2 scaled = uv * scale;
  return Vec2(c * scaled.x + s * scaled.y, -s * scaled.x + c * scaled.y) + offset;
}

}  // namespace lensfarm
