// texture/texture.h: bilinear lookups, glTF's wrap modes, the mip-map pyramid and the footprint's
// choice of level, KHR_texture_transform, and coordinates far outside [0, 1].
#include "common/texture/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace lensfarm {
namespace {

// An image whose texel (x, y) has the values f(x, y) in R, and G, B, A derived from it.
template <typename F>
RgbaImage imageOf(int width, int height, F f) {
  RgbaImage image;
  image.width = width;
  image.height = height;
  image.texels.resize(4 * size_t(width) * size_t(height));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float v = f(x, y);
      const size_t k = 4 * (size_t(y) * size_t(width) + size_t(x));
      image.texels[k] = v;
      image.texels[k + 1] = 2.0f * v;
      image.texels[k + 2] = v + 1.0f;
      image.texels[k + 3] = 1.0f;
    }
  return image;
}

RgbaImage randomImage(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  RgbaImage image;
  image.width = width;
  image.height = height;
  image.texels.resize(4 * size_t(width) * size_t(height));
  for (float& t : image.texels) t = u(rng);
  return image;
}

Vec2 centreOf(int x, int y, int width, int height) {
  return Vec2((float(x) + 0.5f) / float(width), (float(y) + 0.5f) / float(height));
}

TEST(Texture, BilinearAtTexelCentresReturnsTheTexels) {
  for (const auto& [w, h] : {std::pair{4, 2}, std::pair{8, 8}, std::pair{3, 5}, std::pair{7, 1}}) {
    const RgbaImage image = randomImage(w, h, uint32_t(w * 10 + h));
    for (Wrap wrap : {Wrap::kRepeat, Wrap::kMirroredRepeat, Wrap::kClampToEdge}) {
      const Texture texture("random", image, wrap, wrap);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          EXPECT_EQ(texture.bilinear(centreOf(x, y, w, h), 0), image.at(x, y)) << w << "x" << h << " " << x << "," << y;
          EXPECT_EQ(texture.sample(centreOf(x, y, w, h)), image.at(x, y));
        }
    }
  }
}

TEST(Texture, BilinearInterpolatesBetweenTexelCentres) {
  const Texture texture("ramp", imageOf(4, 1, [](int x, int) { return float(x); }));
  EXPECT_FLOAT_EQ(texture.bilinear(Vec2(0.25f, 0.5f), 0).r, 0.5f);  // halfway between texels 0 and 1
  EXPECT_FLOAT_EQ(texture.bilinear(Vec2(0.3125f, 0.5f), 0).r, 0.75f);
  EXPECT_FLOAT_EQ(texture.bilinear(Vec2(0.3125f, 0.5f), 0).g, 1.5f);
}

// Texels 0, 1, 2, 3 along u (or v): which value a coordinate reads under each wrap mode.
TEST(Texture, WrapModesFollowGltf) {
  const RgbaImage row = imageOf(4, 1, [](int x, int) { return float(x); });
  const RgbaImage column = imageOf(1, 4, [](int, int y) { return float(y); });
  struct Case {
    Wrap wrap;
    float u, expected;
  };
  const Case cases[] = {
      // REPEAT: -0.25 is 0.75 (between texels 2 and 3), 1.25 is 0.25 (between 0 and 1).
      {Wrap::kRepeat, -0.25f, 2.5f},
      {Wrap::kRepeat, 1.25f, 0.5f},
      {Wrap::kRepeat, 2.125f, 0.0f},
      {Wrap::kRepeat, 0.0f, 1.5f},  // the edge: halfway between texel 3 and texel 0
      // MIRRORED_REPEAT: -0.25 reads 0.25, 1.25 reads 0.75, 2.25 reads 0.25 again.
      {Wrap::kMirroredRepeat, -0.25f, 0.5f},
      {Wrap::kMirroredRepeat, 1.25f, 2.5f},
      {Wrap::kMirroredRepeat, 2.25f, 0.5f},
      {Wrap::kMirroredRepeat, 0.0f, 0.0f},  // the mirror's edge repeats texel 0
      {Wrap::kMirroredRepeat, 1.0f, 3.0f},
      // CLAMP_TO_EDGE: the edge texels beyond [0, 1].
      {Wrap::kClampToEdge, -0.25f, 0.0f},
      {Wrap::kClampToEdge, 1.25f, 3.0f},
      {Wrap::kClampToEdge, -1e9f, 0.0f},
      {Wrap::kClampToEdge, 1e9f, 3.0f},
  };
  for (const Case& c : cases) {
    const Texture u("row", row, c.wrap, Wrap::kRepeat), v("column", column, Wrap::kRepeat, c.wrap);
    EXPECT_FLOAT_EQ(u.bilinear(Vec2(c.u, 0.5f), 0).r, c.expected) << int(c.wrap) << " u = " << c.u;
    EXPECT_FLOAT_EQ(v.bilinear(Vec2(0.5f, c.u), 0).r, c.expected) << int(c.wrap) << " v = " << c.u;
  }
  // The other axis's mode does not leak: u clamps while v repeats.
  const Texture mixed("mixed", imageOf(4, 4, [](int x, int y) { return float(x + 10 * y); }), Wrap::kClampToEdge,
                      Wrap::kRepeat);
  EXPECT_FLOAT_EQ(mixed.bilinear(Vec2(-3.0f, 1.125f), 0).r, 0.0f);  // x clamped to 0, y = 0.125 -> row 0
  EXPECT_FLOAT_EQ(mixed.bilinear(Vec2(1.5f, 0.625f), 0).r, 3.0f + 20.0f);
}

TEST(Texture, NearestFilterReadsTheTexelUnderThePoint) {
  const Texture texture("pixels", imageOf(4, 1, [](int x, int) { return float(x); }), Wrap::kRepeat, Wrap::kRepeat,
                        TextureFilter::kNearest);
  EXPECT_EQ(texture.sample(Vec2(0.3f, 0.5f)).r, 1.0f);
  EXPECT_EQ(texture.sample(Vec2(0.3f, 0.5f), 1.0f).r, 1.0f);  // no mip-mapping either
  EXPECT_EQ(texture.sample(Vec2(-0.1f, 0.5f)).r, 3.0f);
}

TEST(Texture, CoarsestLevelIsTheMean) {
  // A 2x2 checker: its one-texel level is grey.
  RgbaImage checker;
  checker.width = checker.height = 2;
  checker.texels = {1, 1, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1, 1};
  const Texture texture("checker", checker);
  ASSERT_EQ(texture.levels(), 2);
  EXPECT_EQ(texture.level(1).width, 1);
  EXPECT_EQ(texture.level(1).at(0, 0), Vec4(0.5f, 0.5f, 0.5f, 1.0f));
  // Any size, odd ones included: every level keeps the image's mean.
  for (const auto& [w, h] : {std::pair{8, 4}, std::pair{3, 3}, std::pair{5, 2}, std::pair{7, 13}, std::pair{1, 6}}) {
    const RgbaImage image = randomImage(w, h, uint32_t(w * h));
    Vec4 mean(0.0f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) mean += image.at(x, y) / float(w * h);
    const Texture t("random", image);
    EXPECT_EQ(t.level(t.levels() - 1).width, 1);
    EXPECT_EQ(t.level(t.levels() - 1).height, 1);
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(t.level(t.levels() - 1).at(0, 0)[c], mean[c], 1e-5f) << w << "x" << h;
    for (int k = 0; k < t.levels(); ++k) {
      Vec4 levelMean(0.0f);
      const RgbaImage& level = t.level(k);
      for (int y = 0; y < level.height; ++y)
        for (int x = 0; x < level.width; ++x) levelMean += level.at(x, y) / float(level.width * level.height);
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(levelMean[c], mean[c], 1e-5f) << w << "x" << h << " level " << k;
    }
  }
}

TEST(Texture, FootprintSelectsTheLevel) {
  const RgbaImage image = randomImage(8, 8, 3);
  const Texture texture("random", image);
  ASSERT_EQ(texture.levels(), 4);  // 8, 4, 2, 1
  const Vec2 uv(0.3f, 0.6f);
  // No footprint, or one narrower than a texel: the image itself.
  EXPECT_EQ(texture.sample(uv, 0.0f), texture.bilinear(uv, 0));
  EXPECT_EQ(texture.sample(uv, 1.0f / 8.0f), texture.bilinear(uv, 0));
  // Two texels wide: level 1; four: level 2; between them, a blend by log2.
  EXPECT_EQ(texture.sample(uv, 2.0f / 8.0f), texture.bilinear(uv, 1));
  EXPECT_EQ(texture.sample(uv, 4.0f / 8.0f), texture.bilinear(uv, 2));
  const float t = std::log2(3.0f) - 1.0f;
  const Vec4 blend = texture.bilinear(uv, 1) + t * (texture.bilinear(uv, 2) - texture.bilinear(uv, 1));
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(texture.sample(uv, 3.0f / 8.0f)[c], blend[c], 1e-6f);
  // The whole texture (or more) in one pixel: the mean, wherever the point is.
  const Vec4 mean = texture.level(3).at(0, 0);
  for (float footprint : {1.0f, 10.0f, 1e30f}) {
    EXPECT_EQ(texture.sample(uv, footprint), mean);
    EXPECT_EQ(texture.sample(Vec2(-7.2f, 0.01f), footprint), mean);
  }
}

TEST(Texture, TransformFollowsKhrTextureTransform) {
  TextureTransform rotate;
  rotate.rotation = float(M_PI / 2.0);
  // The extension's rotation in glTF's v-down space: (u, v) -> (cos u + sin v, -sin u + cos v),
  // so (1, 0) goes to (0, -1) and (0, 1) to (1, 0).
  const Vec2 a = rotate.apply(Vec2(1.0f, 0.0f)), b = rotate.apply(Vec2(0.0f, 1.0f));
  EXPECT_NEAR(a.x, 0.0f, 1e-6f);
  EXPECT_NEAR(a.y, -1.0f, 1e-6f);
  EXPECT_NEAR(b.x, 1.0f, 1e-6f);
  EXPECT_NEAR(b.y, 0.0f, 1e-6f);

  // The extension's example: offset [0, 1], rotation pi/2, scale [0.5, 0.5] "utilizes only the
  // lower left quadrant of the source image, rotated clockwise 90 degrees".
  TextureTransform example;
  example.offset = Vec2(0.0f, 1.0f);
  example.rotation = float(M_PI / 2.0);
  example.scale = Vec2(0.5f);
  const std::pair<Vec2, Vec2> corners[] = {{Vec2(0, 0), Vec2(0.0f, 1.0f)},
                                           {Vec2(1, 0), Vec2(0.0f, 0.5f)},
                                           {Vec2(0, 1), Vec2(0.5f, 1.0f)},
                                           {Vec2(1, 1), Vec2(0.5f, 0.5f)}};
  for (const auto& [in, out] : corners) {
    const Vec2 got = example.apply(in);
    EXPECT_NEAR(got.x, out.x, 1e-6f) << in.x << ", " << in.y;
    EXPECT_NEAR(got.y, out.y, 1e-6f) << in.x << ", " << in.y;
  }

  // Scale first, then offset; the identity leaves coordinates alone.
  TextureTransform scaleOffset;
  scaleOffset.scale = Vec2(2.0f, 3.0f);
  scaleOffset.offset = Vec2(0.25f, -0.5f);
  EXPECT_EQ(scaleOffset.apply(Vec2(1.0f, 1.0f)), Vec2(2.25f, 2.5f));
  EXPECT_TRUE(TextureTransform().identity());
  EXPECT_EQ(TextureTransform().apply(Vec2(0.3f, 0.7f)), Vec2(0.3f, 0.7f));
}

TEST(Texture, TextureRefScalesTheFootprintWithTheTransform) {
  auto texture = std::make_shared<const Texture>("random", randomImage(8, 8, 5));
  TextureRef ref;
  ref.texture = texture;
  ref.uvSet = 1;
  ref.transform.scale = Vec2(2.0f, 0.5f);
  const Vec2 uv[2] = {Vec2(0.9f, 0.9f), Vec2(0.1f, 0.2f)};
  // TEXCOORD_1, scaled: (0.2, 0.1); a footprint of 1/8 covers 2 texels after the scale of 2.
  EXPECT_EQ(ref.coordinates(uv), Vec2(0.2f, 0.1f));
  EXPECT_EQ(ref.sample(uv, 1.0f / 8.0f), texture->bilinear(Vec2(0.2f, 0.1f), 1));
}

TEST(Texture, FarCoordinatesKeepTheirFractionalPosition) {
  const RgbaImage image = randomImage(16, 16, 7);
  for (Wrap wrap : {Wrap::kRepeat, Wrap::kMirroredRepeat}) {
    const Texture texture("random", image, wrap, wrap);
    // 2^20 + 0.25 is exact in float (its spacing there is 1/8): it must read what 0.25 reads,
    // not what float rounding of (u * 16 - 0.5) at 1.6e7 would give.
    const float far = 1048576.25f;
    ASSERT_EQ(far - 1048576.0f, 0.25f);
    EXPECT_EQ(texture.bilinear(Vec2(far, 0.4f), 0), texture.bilinear(Vec2(0.25f, 0.4f), 0));
    EXPECT_EQ(texture.bilinear(Vec2(0.4f, far), 0), texture.bilinear(Vec2(0.4f, 0.25f), 0));
    EXPECT_EQ(texture.bilinear(Vec2(-1048575.75f, 0.4f), 0), texture.bilinear(Vec2(0.25f, 0.4f), 0));
    // Just below 2^23, where float still holds halves.
    EXPECT_EQ(texture.bilinear(Vec2(8388606.5f, 0.4f), 0), texture.bilinear(Vec2(0.5f, 0.4f), 0));
    // 1e7 + 0.25 is the float 1e7 (spacing 1): it reads what 0 reads, the nearest float's value.
    EXPECT_EQ(texture.bilinear(Vec2(float(1e7 + 0.25), 0.4f), 0), texture.bilinear(Vec2(0.0f, 0.4f), 0));
    // Non-finite coordinates read something rather than crash.
    EXPECT_TRUE(std::isfinite(texture.sample(Vec2(NAN, INFINITY), 0.5f).r));
  }
}

TEST(Texture, BytesCountEveryLevel) {
  const Texture texture("random", randomImage(4, 2, 1));
  EXPECT_EQ(texture.levels(), 3);  // 4x2, 2x1, 1x1
  EXPECT_EQ(texture.bytes(), (8 + 2 + 1) * 4 * sizeof(float));
  EXPECT_EQ(texture.width(), 4);
  EXPECT_EQ(texture.height(), 2);
  EXPECT_EQ(texture.name(), "random");
}

}  // namespace
}  // namespace lensfarm
