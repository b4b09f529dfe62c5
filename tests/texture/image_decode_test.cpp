// texture/image_decode.h: PNG (8- and 16-bit, grey, grey + alpha, RGB, RGBA), JPEG, Radiance HDR
// and EXR decoded to linear RGBA, and every kind of bad file refused with one InputError naming it.
#include "common/texture/image_decode.h"

#include <gtest/gtest.h>

#include <cstdlib>

#include <cmath>
#include <string>
#include <vector>

#include "common/film/image_io.h"
#include "common/util/error.h"
#include "tests/texture/test_images.h"

namespace lensfarm {
namespace {

using test::hdr;
using test::jpeg;
using test::png16;
using test::png8;

// The message of the InputError that decoding throws, or "" if it does not.
std::string errorOf(const std::string& bytes, const std::string& name = "tex.png") {
  try {
    decodeImage(bytes, name, ColorEncoding::kSrgb);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

TEST(ImageDecode, SrgbTransferFunctionMatchesPublishedValues) {
  // IEC 61966-2-1: linear = ((c + 0.055) / 1.055)^2.4 above 0.04045, c / 12.92 below.
  EXPECT_NEAR(srgbToLinear(0.5f), 0.214041f, 1e-6f);
  EXPECT_NEAR(srgbToLinear(0.735357f), 0.5f, 1e-6f);  // the published encoding of linear 0.5
  EXPECT_EQ(srgbToLinear(1.0f), 1.0f);
  EXPECT_EQ(srgbToLinear(0.0f), 0.0f);
  EXPECT_FLOAT_EQ(srgbToLinear(0.02f), 0.02f / 12.92f);
  EXPECT_FLOAT_EQ(srgbToLinear(0.04045f), 0.04045f / 12.92f);
  // Continuous at the knee, and increasing.
  EXPECT_NEAR(srgbToLinear(0.040451f), 0.04045f / 12.92f, 1e-6f);
  for (int k = 1; k <= 255; ++k) EXPECT_LT(srgbToLinear(float(k - 1) / 255.0f), srgbToLinear(float(k) / 255.0f));
}

TEST(ImageDecode, Png8BitColourIsDecodedFromSrgbAndAlphaIsLinear) {
  const std::string png = png8(2, 1, 4, {255, 128, 0, 128, 0, 64, 255, 255});
  const RgbaImage srgb = decodeImage(png, "tex.png", ColorEncoding::kSrgb);
  ASSERT_EQ(srgb.width, 2);
  ASSERT_EQ(srgb.height, 1);
  ASSERT_EQ(srgb.texels.size(), 8u);
  EXPECT_EQ(srgb.at(0, 0).r, 1.0f);
  EXPECT_FLOAT_EQ(srgb.at(0, 0).g, srgbToLinear(128.0f / 255.0f));
  EXPECT_EQ(srgb.at(0, 0).b, 0.0f);
  EXPECT_FLOAT_EQ(srgb.at(0, 0).a, 128.0f / 255.0f);  // alpha is never sRGB
  EXPECT_FLOAT_EQ(srgb.at(1, 0).g, srgbToLinear(64.0f / 255.0f));
  EXPECT_EQ(srgb.at(1, 0).a, 1.0f);

  // A data role (roughness, normals) takes the values as they are.
  const RgbaImage linear = decodeImage(png, "tex.png", ColorEncoding::kLinear);
  EXPECT_FLOAT_EQ(linear.at(0, 0).g, 128.0f / 255.0f);
  EXPECT_FLOAT_EQ(linear.at(1, 0).g, 64.0f / 255.0f);
  EXPECT_FLOAT_EQ(linear.at(0, 0).a, 128.0f / 255.0f);
}

TEST(ImageDecode, GreyFillsRgbAndMissingAlphaIsOne) {
  const RgbaImage grey = decodeImage(png8(2, 1, 1, {0, 200}), "grey.png", ColorEncoding::kLinear);
  EXPECT_EQ(grey.at(1, 0), Vec4(200.0f / 255.0f, 200.0f / 255.0f, 200.0f / 255.0f, 1.0f));
  EXPECT_EQ(grey.at(0, 0), Vec4(0.0f, 0.0f, 0.0f, 1.0f));

  const RgbaImage greyAlpha = decodeImage(png8(1, 1, 2, {200, 51}), "ga.png", ColorEncoding::kSrgb);
  const float g = srgbToLinear(200.0f / 255.0f);
  EXPECT_EQ(greyAlpha.at(0, 0), Vec4(g, g, g, 51.0f / 255.0f));

  const RgbaImage rgb = decodeImage(png8(1, 1, 3, {10, 20, 30}), "rgb.png", ColorEncoding::kLinear);
  EXPECT_EQ(rgb.at(0, 0), Vec4(10.0f / 255.0f, 20.0f / 255.0f, 30.0f / 255.0f, 1.0f));
}

TEST(ImageDecode, RowsStayTopFirst) {
  // Row 0 (red) is the top of the image: v = 0 in glTF's convention (texture/texture.h).
  const RgbaImage image = decodeImage(png8(1, 2, 3, {255, 0, 0, 0, 0, 255}), "rows.png", ColorEncoding::kLinear);
  EXPECT_EQ(image.at(0, 0), Vec4(1.0f, 0.0f, 0.0f, 1.0f));
  EXPECT_EQ(image.at(0, 1), Vec4(0.0f, 0.0f, 1.0f, 1.0f));
}

TEST(ImageDecode, SixteenBitPngKeepsItsPrecision) {
  const std::string rgb = png16(2, 1, PNG_COLOR_TYPE_RGB, {65535, 32768, 0, 1, 257, 65534});
  const RgbaImage linear = decodeImage(rgb, "deep.png", ColorEncoding::kLinear);
  EXPECT_EQ(linear.at(0, 0), Vec4(1.0f, 32768.0f / 65535.0f, 0.0f, 1.0f));
  EXPECT_FLOAT_EQ(linear.at(1, 0).r, 1.0f / 65535.0f);  // not representable in 8 bits
  EXPECT_FLOAT_EQ(linear.at(1, 0).b, 65534.0f / 65535.0f);
  const RgbaImage srgb = decodeImage(rgb, "deep.png", ColorEncoding::kSrgb);
  EXPECT_FLOAT_EQ(srgb.at(0, 0).g, srgbToLinear(32768.0f / 65535.0f));
  EXPECT_FLOAT_EQ(srgb.at(1, 0).r, srgbToLinear(1.0f / 65535.0f));

  const RgbaImage greyAlpha =
      decodeImage(png16(1, 1, PNG_COLOR_TYPE_GRAY_ALPHA, {40000, 1000}), "ga16.png", ColorEncoding::kSrgb);
  const float g = srgbToLinear(40000.0f / 65535.0f);
  EXPECT_FLOAT_EQ(greyAlpha.at(0, 0).r, g);
  EXPECT_FLOAT_EQ(greyAlpha.at(0, 0).g, g);
  EXPECT_FLOAT_EQ(greyAlpha.at(0, 0).b, g);
  EXPECT_FLOAT_EQ(greyAlpha.at(0, 0).a, 1000.0f / 65535.0f);
}

TEST(ImageDecode, JpegDecodesFromSrgb) {
  std::vector<uint8_t> pixels;
  for (int k = 0; k < 16 * 16; ++k) pixels.insert(pixels.end(), {200, 100, 50});
  const RgbaImage image = decodeImage(jpeg(16, 16, 3, pixels), "photo.jpg", ColorEncoding::kSrgb);
  ASSERT_EQ(image.width, 16);
  ASSERT_EQ(image.height, 16);
  // Lossy (and chroma-subsampled): within a few codes of the encoded values.
  const Vec4 v = image.at(7, 7);
  EXPECT_NEAR(v.r, srgbToLinear(200.0f / 255.0f), 0.02f);
  EXPECT_NEAR(v.g, srgbToLinear(100.0f / 255.0f), 0.01f);
  EXPECT_NEAR(v.b, srgbToLinear(50.0f / 255.0f), 0.01f);
  EXPECT_EQ(v.a, 1.0f);
}

TEST(ImageDecode, RadianceHdrIsLinearWhateverTheEncoding) {
  const std::string file = hdr(2, 1, 3, {0.5f, 2.0f, 100.0f, 0.0f, 0.25f, 1.0f});
  for (ColorEncoding encoding : {ColorEncoding::kSrgb, ColorEncoding::kLinear}) {
    const RgbaImage image = decodeImage(file, "sky.hdr", encoding);
    ASSERT_EQ(image.width, 2);
    // RGBE keeps 8 bits of mantissa under a shared exponent.
    EXPECT_NEAR(image.at(0, 0).r, 0.5f, 0.5f / 128.0f);
    EXPECT_NEAR(image.at(0, 0).g, 2.0f, 100.0f / 128.0f);
    EXPECT_NEAR(image.at(0, 0).b, 100.0f, 100.0f / 128.0f);
    EXPECT_EQ(image.at(0, 0).a, 1.0f);
    EXPECT_NEAR(image.at(1, 0).g, 0.25f, 1.0f / 128.0f);
    EXPECT_NEAR(image.at(1, 0).b, 1.0f, 1.0f / 128.0f);
  }
}

TEST(ImageDecode, ExrIsLinearAndExact) {
  Image rgb;
  rgb.width = 2;
  rgb.height = 2;
  rgb.rgb = {0.0f, 0.5f, 1.0f, 1000.0f, 0.125f, 3.0f, 0.01f, 0.02f, 0.03f, 7.0f, 8.0f, 9.0f};
  const RgbaImage image = decodeImage(encodeExr(rgb, {}), "env.exr", ColorEncoding::kSrgb);
  ASSERT_EQ(image.width, 2);
  ASSERT_EQ(image.height, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 2; ++x) EXPECT_EQ(image.at(x, y), Vec4(rgb.at(x, y), 1.0f)) << x << ", " << y;
}

TEST(ImageDecode, NegativeOrNonFiniteFloatTexelsAreRefusedNamingThePixel) {
  Image rgb;
  rgb.width = 3;
  rgb.height = 2;
  rgb.rgb.assign(18, 0.5f);
  rgb.rgb[3 * (1 * 3 + 2) + 1] = -1.0f;  // pixel (2, 1), G
  std::string message = errorOf(encodeExr(rgb, {}), "env.exr");
  EXPECT_TRUE(startsWith(message, "env.exr: ")) << message;
  EXPECT_NE(message.find("pixel (2, 1) channel G is -1"), std::string::npos) << message;
  rgb.rgb[3 * (1 * 3 + 2) + 1] = std::nanf("");
  message = errorOf(encodeExr(rgb, {}), "env.exr");
  EXPECT_NE(message.find("pixel (2, 1) channel G is not finite"), std::string::npos) << message;
}

TEST(ImageDecode, UnknownFormatsAreRefusedWithTheirFirstBytes) {
  EXPECT_EQ(errorOf("GIF89a\x01\x00\x01\x00", "model.glb: images[3]"),
            "model.glb: images[3]: not a PNG, JPEG, HDR or EXR image (starts with 47 49 46 38)");
  EXPECT_EQ(errorOf("", "tex.png"), "tex.png: not a PNG, JPEG, HDR or EXR image (the file is empty)");
  EXPECT_EQ(errorOf("BM", "tex.bmp"), "tex.bmp: not a PNG, JPEG, HDR or EXR image (starts with 42 4d)");
  // TGA has no magic: bytes stb_image would take for one are refused all the same.
  EXPECT_TRUE(startsWith(errorOf(std::string("\x00\x00\x02\x00\x00\x00\x00\x00\x00\x00\x00\x00\x01\x00\x01\x00\x18\x00"
                                             "\xFF\xFF\xFF",
                                             21),
                                 "tex.tga"),
                         "tex.tga: not a PNG, JPEG, HDR or EXR image (starts with 00 00 02 00)"));
}

TEST(ImageDecode, TruncatedFilesAreRefusedNamingTheFormat) {
  const std::string png = png8(8, 8, 3, std::vector<uint8_t>(8 * 8 * 3, 77));
  for (size_t keep : {size_t(8), size_t(20), png.size() / 2, png.size() - 13}) {
    const std::string message = errorOf(png.substr(0, keep));
    EXPECT_TRUE(startsWith(message, "tex.png: truncated or corrupt PNG (stb_image: ")) << keep << ": " << message;
  }
  std::vector<uint8_t> pixels(16 * 16 * 3, 99);
  const std::string jpg = jpeg(16, 16, 3, pixels);
  const std::string message = errorOf(jpg.substr(0, jpg.size() / 3), "photo.jpg");
  EXPECT_TRUE(startsWith(message, "photo.jpg: truncated or corrupt JPEG (stb_image: ")) << message;

  Image rgb;
  rgb.width = rgb.height = 16;
  rgb.rgb.assign(16 * 16 * 3, 0.25f);
  const std::string exr = encodeExr(rgb, {});
  for (size_t keep : {size_t(6), size_t(40), exr.size() / 2}) {
    const std::string m = errorOf(exr.substr(0, keep), "env.exr");
    EXPECT_TRUE(startsWith(m, "env.exr: truncated or corrupt EXR (")) << keep << ": " << m;
  }
}

TEST(ImageDecode, SizesBeyondTheLimitAreRefusedBeforeDecoding) {
  const std::string png = png8(2, 2, 3, std::vector<uint8_t>(12, 1));
  // 100000 x 100000 RGBA float would take 160 GB: the header alone decides.
  EXPECT_EQ(errorOf(test::withPngSize(png, 100000, 100000)),
            "tex.png: PNG of 100000 x 100000 pixels: each side must be 1 to 32768");
  EXPECT_EQ(errorOf(test::withPngSize(png, 40000, 1)),
            "tex.png: PNG of 40000 x 1 pixels: each side must be 1 to 32768");
  // A zero side: stb_image refuses the header itself.
  EXPECT_TRUE(startsWith(errorOf(test::withPngSize(png, 0, 2)), "tex.png: ")) << errorOf(test::withPngSize(png, 0, 2));

  // Radiance HDR's resolution line.
  EXPECT_EQ(errorOf("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 50000 +X 2\n" + std::string(16, '\x01'), "sky.hdr"),
            "sky.hdr: Radiance HDR of 2 x 50000 pixels: each side must be 1 to 32768");

  // EXR's dataWindow, read before OpenEXR allocates anything.
  Image rgb;
  rgb.width = rgb.height = 2;
  rgb.rgb.assign(12, 1.0f);
  std::string exr = encodeExr(rgb, {});
  const size_t at = exr.find(std::string("dataWindow\0box2i\0", 17));
  ASSERT_NE(at, std::string::npos);
  const size_t box = at + 17 + 4;  // after the size field: xMin, yMin, xMax, yMax (little-endian)
  exr[box + 8] = '\x9F';           // xMax = 99999 (0x1869F)
  exr[box + 9] = '\x86';
  exr[box + 10] = '\x01';
  EXPECT_EQ(errorOf(exr, "env.exr"), "env.exr: EXR of 100000 x 2 pixels: each side must be 1 to 32768");
}

// A texture within the side limit that would not fit in one job's memory once decoded (float
// RGBA with its mip levels) is refused from its header, naming the budget: decoding it could
// take the machine down before any estimate refused the job.
TEST(ImageDecode, ATextureBeyondTheJobMemoryBudgetIsRefusedBeforeDecoding) {
  const char* set = std::getenv("LENSFARM_MAX_JOB_MEMORY");
  const std::string saved = set ? set : "";
  ::setenv("LENSFARM_MAX_JOB_MEMORY", "1G", 1);
  const std::string png = png8(2, 2, 3, std::vector<uint8_t>(12, 1));
  // 8192 x 8192 x 16 bytes x 4/3 = 1.43 GB > 1 GiB; 4096 x 4096 (358 MB) is decoded as usual
  // (and stb then finds the data truncated).
  EXPECT_EQ(errorOf(test::withPngSize(png, 8192, 8192)),
            "tex.png: PNG of 8192 x 8192 pixels decodes to 1.43 GB with its mip levels, more than the 1.07 GB "
            "allowed per job (LENSFARM_MAX_JOB_MEMORY); lower its resolution, or set LENSFARM_MAX_JOB_MEMORY if "
            "this machine can hold it");
  EXPECT_EQ(errorOf(test::withPngSize(png, 4096, 4096)).find("allowed per job"), std::string::npos);
  if (set)
    ::setenv("LENSFARM_MAX_JOB_MEMORY", saved.c_str(), 1);
  else
    ::unsetenv("LENSFARM_MAX_JOB_MEMORY");
}

}  // namespace
}  // namespace lensfarm
