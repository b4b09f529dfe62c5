// The faster output path (docs/performance.md "Everything around the render") writes the same
// image: the table-driven sRGB quantizer gives srgb8's bytes, the exposure the bytes of the
// one-value-at-a-time formula it replaced, the fast PNG deflate decodes (libpng's own reader) to
// those bytes, and an uncompressed EXR decodes (OpenEXR) to the same floats and header as a ZIP one.
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <gtest/gtest.h>
#include <png.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "common/film/exposure.h"
#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

// What exposeToSrgb8 computed before the quantizer and the threads: one value at a time, with pow.
std::vector<uint8_t> referenceExposure(const Image& image, const ExposureSettings& settings) {
  const double scaleD = exposureScale(image, settings.meter) * std::exp2(settings.ev);
  const float scale = float(scaleD);
  const bool inFloat = std::isnormal(scale);
  std::vector<uint8_t> out(image.rgb.size());
  for (size_t k = 0; k < image.rgb.size(); ++k) {
    float v = inFloat ? image.rgb[k] * scale : float(double(image.rgb[k]) * scaleD);
    v = std::min(std::max(0.0f, v), std::numeric_limits<float>::max());
    if (settings.toneMap == ToneMap::kReinhard) v = v / (1.0f + v);
    const float x = std::clamp(v, 0.0f, 1.0f);
    const float srgb = x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
    out[k] = uint8_t(std::lround(srgb * 255.0f));
  }
  return out;
}

// A noisy render-like image: exponential radiance, some black, a few fireflies and extremes.
Image noisyImage(int width, int height, uint32_t seed) {
  Image image{width, height, {}};
  std::mt19937 rng(seed);
  std::exponential_distribution<float> radiance(2.0f);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < width * height * 3; ++k) {
    const float p = u(rng);
    image.rgb.push_back(p < 0.05f ? 0.0f : p > 0.999f ? 1e4f * radiance(rng) : radiance(rng));
  }
  image.rgb[7] = std::numeric_limits<float>::denorm_min();
  image.rgb[8] = 3e38f;
  return image;
}

std::vector<uint8_t> decodePng(const std::string& bytes, int* width, int* height) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  EXPECT_TRUE(png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) << png.message;
  png.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  EXPECT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
  *width = int(png.width);
  *height = int(png.height);
  return pixels;
}

TEST(Srgb8Quantizer, GivesSrgb8sByteAroundEveryStepAndElsewhere) {
  const Srgb8Quantizer& q = Srgb8Quantizer::instance();
  // Where a wrong table would show first: the 8193 floats centred on each of the 255 steps.
  for (size_t i = 0; i < 255; ++i) {
    const uint32_t step = std::bit_cast<uint32_t>(q.thresholds()[i]);
    ASSERT_EQ(srgb8(q.thresholds()[i]), i + 1);
    ASSERT_EQ(srgb8(std::bit_cast<float>(step - 1)), i)
        << "the step of " << i + 1 << " is not the least float reaching it";
    for (uint32_t b = step > 4096 ? step - 4096 : 0; b <= step + 4096 && b <= std::bit_cast<uint32_t>(1.0f); ++b)
      ASSERT_EQ(q(std::bit_cast<float>(b)), srgb8(std::bit_cast<float>(b))) << std::bit_cast<float>(b);
  }
  // A sample of all the others in [0, 1] (every float was checked once, docs/performance.md).
  for (uint32_t b = 0; b <= std::bit_cast<uint32_t>(1.0f); b += 1021)
    ASSERT_EQ(q(std::bit_cast<float>(b)), srgb8(std::bit_cast<float>(b))) << std::bit_cast<float>(b);
  // Above 1, as the clamp in linearToSrgb has it.
  for (float v : {1.0f, std::nextafter(1.0f, 2.0f), 1.5f, 1e30f, std::numeric_limits<float>::max()})
    EXPECT_EQ(q(v), 255) << v;
  EXPECT_EQ(q(0.0f), 0);
  for (float v : {-0.0f, -1.0f, -std::numeric_limits<float>::infinity(), std::nanf("")}) EXPECT_EQ(q(v), 0) << v;
}

TEST(ImageOutput, ExposureGivesTheBytesOfThePerValueFormula) {
  const Image image = noisyImage(257, 131, 5);  // not a multiple of any block size
  for (ToneMap toneMap : {ToneMap::kReinhard, ToneMap::kClamp})
    for (double ev : {0.0, -3.5, 2.0, 64.0, -64.0})
      EXPECT_EQ(exposeToSrgb8(image, ExposureSettings{ev, toneMap}), referenceExposure(image, {ev, toneMap}))
          << "ev " << ev;
  // An image so dim that its scale is beyond float: the double path.
  Image dim{2, 1, {1e-44f, 2e-44f, 0.0f, 3e-45f, 1e-45f, 5e-45f}};
  EXPECT_EQ(exposeToSrgb8(dim, {}), referenceExposure(dim, {}));
}

TEST(ImageOutput, PngDecodesToTheExposedBytes) {
  // Noise (hardly compressible) and a smooth gradient (where the Up filter and RLE pay).
  Image smooth{300, 200, {}};
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 300; ++x)
      for (int c = 0; c < 3; ++c) smooth.rgb.push_back(0.01f * float(x + 2 * y + 40 * c));
  for (const Image& image : {noisyImage(123, 77, 9), smooth}) {
    const ExposureSettings exposure{0.5, ToneMap::kReinhard};
    const std::string png = encodePng(image, exposure);
    int width = 0, height = 0;
    EXPECT_EQ(decodePng(png, &width, &height), exposeToSrgb8(image, exposure));
    EXPECT_EQ(width, image.width);
    EXPECT_EQ(height, image.height);
  }
  // The smooth image is compressed, not merely stored (a stored PNG is larger than its pixels).
  EXPECT_LT(encodePng(smooth, {}).size(), smooth.rgb.size() / 4);
}

Imf::Compression compressionOf(const std::string& exr) {
  Imf::StdISStream stream;
  stream.str(exr);
  Imf::InputFile file(stream);
  return file.header().compression();
}

TEST(ImageOutput, UncompressedExrHoldsTheSameFloatsAndHeaderAsZip) {
  const Image image = noisyImage(64, 37, 3);
  ImageMetadata m;
  m.samplesPerPixel = 16;
  m.totalSamples = 16ull * 64 * 37;
  m.renderSeconds = 0.25;
  m.sceneHash = "cafe";
  m.rendererVersion = "v-test";
  m.extra["workers"] = "local";
  const std::string zip = encodeExr(image, m), none = encodeExr(image, m, ExrCompression::kNone);
  EXPECT_EQ(compressionOf(zip), Imf::ZIP_COMPRESSION);  // the farm's default, unchanged
  EXPECT_EQ(compressionOf(none), Imf::NO_COMPRESSION);
  ImageMetadata fromZip, fromNone;
  const Image a = decodeExr(zip, &fromZip), b = decodeExr(none, &fromNone);
  EXPECT_EQ(a.rgb, image.rgb);
  EXPECT_EQ(b.rgb, image.rgb);
  EXPECT_EQ(b.width, image.width);
  EXPECT_EQ(b.height, image.height);
  for (const ImageMetadata* read : {&fromZip, &fromNone}) {
    EXPECT_EQ(read->samplesPerPixel, 16u);
    EXPECT_EQ(read->totalSamples, m.totalSamples);
    EXPECT_EQ(read->renderSeconds, 0.25);
    EXPECT_EQ(read->sceneHash, "cafe");
    EXPECT_EQ(read->rendererVersion, "v-test");
    EXPECT_EQ(read->extra.at("workers"), "local");
  }
  // And through a file, as `lensfarm render` writes it.
  test::TempDir dir;
  writeImageFile(dir / "x.exr", image, m, {}, ExrCompression::kNone);
  EXPECT_EQ(readExr(dir / "x.exr").rgb, image.rgb);
}

}  // namespace
}  // namespace lensfarm
