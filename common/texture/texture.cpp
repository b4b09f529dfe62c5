#include "common/texture/texture.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace lensfarm {

namespace {
// The weights by which the texels of a side of `in` texels make up each texel of the next
// level's side (max(1, in / 2) texels): a box over the same extent, area-weighted, so that an
// odd side keeps every texel and the level's mean stays the image's (an even side: 2 texels of
// weight 1/2).
struct Tap {
  int from;
  float weight;
};
std::vector<std::vector<Tap>> boxTaps(int in) {
  const int out = std::max(1, in / 2);
  const double scale = double(in) / double(out);
  std::vector<std::vector<Tap>> taps(static_cast<size_t>(out));
  for (int o = 0; o < out; ++o) {
    const double lo = o * scale, hi = (o + 1) * scale;
    for (int i = int(std::floor(lo)); i < in && double(i) < hi; ++i) {
      const double overlap = std::min(hi, double(i + 1)) - std::max(lo, double(i));
      if (overlap > 0.0) taps[size_t(o)].push_back({i, float(overlap / scale)});
    }
  }
  return taps;
}

// The next level of the pyramid: each side halved (a side of 1 stays 1), each texel the mean of
// the area of the texels it covers (boxTaps), rows then columns.
RgbaImage halve(const RgbaImage& in) {
  const std::vector<std::vector<Tap>> tx = boxTaps(in.width), ty = boxTaps(in.height);
  RgbaImage out;
  out.width = int(tx.size());
  out.height = int(ty.size());
  out.texels.resize(4 * size_t(out.width) * size_t(out.height));
  std::vector<Vec4> row(size_t(in.width));
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < in.width; ++x) {
      Vec4 sum(0.0f);
      for (const Tap& t : ty[size_t(y)]) sum += t.weight * in.at(x, t.from);
      row[size_t(x)] = sum;
    }
    for (int x = 0; x < out.width; ++x) {
      Vec4 mean(0.0f);
      for (const Tap& t : tx[size_t(x)]) mean += t.weight * row[size_t(t.from)];
      const size_t k = 4 * (size_t(y) * size_t(out.width) + size_t(x));
      for (int c = 0; c < 4; ++c) out.texels[k + size_t(c)] = mean[c];
    }
  }
  return out;
}

// A texel index wrapped into [0, size) by glTF's rule.
int wrapIndex(int i, int size, Wrap wrap) {
  switch (wrap) {
    case Wrap::kClampToEdge: return std::clamp(i, 0, size - 1);
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
  // a + t (b - a): exact where the texels are equal (a constant region, a 1x1 level).
  const Vec4 top = img.at(xa, ya) + ax * (img.at(xb, ya) - img.at(xa, ya));
  const Vec4 bottom = img.at(xa, yb) + ax * (img.at(xb, yb) - img.at(xa, yb));
  return top + ay * (bottom - top);
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
  const Vec4 a = bilinear(uv, lo);
  return a + t * (bilinear(uv, lo + 1) - a);
}

Vec2 TextureTransform::apply(Vec2 uv) const {
  if (identity()) return uv;
  // KHR_texture_transform's T * R * S with R = [[cos, sin], [-sin, cos]] (rows): what the
  // extension's example ("offset [0, 1], rotation pi/2, scale 0.5: the lower-left quadrant,
  // rotated") and the implementations do in glTF's v-down space. Its GLSL listing, read
  // column-major, is the transpose (KhronosGroup/glTF issue 1563).
  const float c = std::cos(rotation), s = std::sin(rotation);
  const Vec2 scaled = uv * scale;
  return Vec2(c * scaled.x + s * scaled.y, -s * scaled.x + c * scaled.y) + offset;
}

}  // namespace lensfarm
