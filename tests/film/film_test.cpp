// The sensor, exposure and image files.
#include <gtest/gtest.h>

#include <random>

#include "common/film/exposure.h"
#include "common/film/image_io.h"
#include "common/film/sensor.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

TEST(Sensor, DevelopingUndoesTheLensFlip) {
  Sensor sensor(4, 3);
  SensorBuffer unit(4, 3);
  std::fill(unit.samples.begin(), unit.samples.end(), 1u);
  unit.sums[0] = 7.0;  // cell (0, 0), red: the sensor's upper left
  sensor.add(unit);
  const Image image = sensor.developImage();
  EXPECT_FLOAT_EQ(image.at(3, 2).r, 7.0f);  // shows at the image's lower right
  EXPECT_FLOAT_EQ(image.at(0, 0).r, 0.0f);
}

TEST(Sensor, MeanIsSumOverSamplesAndNeverClamped) {
  Sensor sensor(1, 1);
  SensorBuffer unit(1, 1);
  unit.sums = {30.0, 6.0, 0.0};
  unit.samples = {3};
  sensor.add(unit);
  sensor.add(unit);
  EXPECT_EQ(sensor.totalSamples(), 6u);
  EXPECT_DOUBLE_EQ(sensor.mean(0, 0).x, 10.0);  // values above 1 stay (2013 report §4.7.1)
  EXPECT_DOUBLE_EQ(sensor.mean(0, 0).y, 2.0);
}

TEST(Sensor, LongAccumulationKeepsFullPrecision) {
  // 10^6 units of 0.1 each. A plain double running sum drifts by ~1e-11 relative here; the
  // compensated sum must stay within a few ulps of the exact value N * 0.1.
  Sensor sensor(1, 1);
  SensorBuffer unit(1, 1);
  unit.sums = {0.1, 0.1, 0.1};
  unit.samples = {1};
  const int kUnits = 1'000'000;
  double naive = 0.0;
  for (int k = 0; k < kUnits; ++k) {
    sensor.add(unit);
    naive += 0.1;
  }
  const long double exact = static_cast<long double>(0.1) * kUnits;
  const double total = sensor.mean(0, 0).x * kUnits;
  EXPECT_LT(std::abs((total - exact) / exact), 1e-14L);
  EXPECT_GT(std::abs((naive - exact) / exact), 1e-13L) << "the test would not notice a plain sum";
}

TEST(Exposure, AutomaticExposureMapsTheMeanToOneThenAppliesEvAndToneMap) {
  // The 2013 report's meter: a uniform image of any brightness gives the same picture (§4.7.4,
  // Fig. 5c vs 5d).
  for (float radiance : {0.001f, 1.0f, 5000.0f}) {
    Image image{2, 2, std::vector<float>(12, radiance)};
    for (double ev : {0.0, -1.0}) {
      const auto rgb = exposeToSrgb8(image, ExposureSettings{ev, ToneMap::kReinhard, ExposureMeter::kMean});
      const double v = std::exp2(ev);  // luminance of a grey pixel equals its value
      const double toned = v / (1 + v);
      const double srgb = toned <= 0.0031308 ? 12.92 * toned : 1.055 * std::pow(toned, 1 / 2.4) - 0.055;
      for (uint8_t b : rgb) EXPECT_EQ(b, uint8_t(std::lround(srgb * 255))) << radiance << " ev " << ev;
    }
  }
  Image black{1, 1, {0, 0, 0}};
  EXPECT_EQ(autoExposureScale(black), 1.0);
  EXPECT_EQ(litExposureScale(black), 1.0);
  EXPECT_EQ(exposeToSrgb8(black, {}), std::vector<uint8_t>(3, 0));
}

// The lit meter (the default): the mean luminance of the pixels that see something (a pixel or a
// 3 x 3 neighbour not black) goes to 1. Computed here from that definition.
TEST(Exposure, TheLitMeterMapsTheMeanOfThePixelsThatSeeSomethingToOne) {
  // A 6 x 3 image: a 2 x 1 subject of luminance 1 and 4 in the top left corner, black elsewhere.
  // Seen: the subject and its neighbours (columns 0-2 of rows 0-1): 6 pixels, luminance 5.
  Image image{6, 3, std::vector<float>(54, 0.0f)};
  for (int c = 0; c < 3; ++c) image.rgb[c] = 1.0f, image.rgb[3 + c] = 4.0f;
  EXPECT_NEAR(litExposureScale(image), 6.0 / 5.0, 1e-12);
  // Uniform images of any brightness give the same picture, as with the mean meter.
  for (float radiance : {1e-20f, 0.001f, 1.0f, 5000.0f, 1e30f}) {
    const Image uniform{2, 2, std::vector<float>(12, radiance)};
    EXPECT_NEAR(litExposureScale(uniform) * radiance, 1.0, 1e-6) << radiance;  // luminance in float
  }
  EXPECT_EQ(exposureScale(image, ExposureMeter::kFixed), 1.0);
  EXPECT_EQ(exposureScale(image, ExposureMeter::kMean), autoExposureScale(image));
  EXPECT_EQ(exposureScale(image, ExposureMeter::kLit), litExposureScale(image));
}

TEST(Exposure, ABlackBackgroundDoesNotBlowOutTheSubject) {
  // A 0.6-grey floor lit to radiance 0.6 / pi fills the top two rows of a 10 x 10 frame; the rest
  // is black (a model exported without a world). The mean meter takes the black for dim light and
  // renders the floor white; the lit meter leaves out all of it but the row beside the floor.
  const float floor = 0.6f / 3.14159265f;
  Image image{10, 10, std::vector<float>(300, 0.0f)};
  for (int k = 0; k < 20; ++k) image.rgb[3 * k] = image.rgb[3 * k + 1] = image.rgb[3 * k + 2] = floor;
  const auto seed = exposeToSrgb8(image, ExposureSettings{0.0, ToneMap::kClamp, ExposureMeter::kMean});
  EXPECT_EQ(seed[0], 255);  // 5 x the mean: clipped
  // Seen: rows 0-2 (30 pixels), 20 of them floor: the floor at 30 / 20 = 1.5, after Reinhard
  // 1.5 / 2.5 = 0.6: light grey, not white.
  const auto lit = exposeToSrgb8(image, ExposureSettings{0.0, ToneMap::kReinhard, ExposureMeter::kLit});
  EXPECT_EQ(lit[0], srgb8(1.5f / 2.5f));
  EXPECT_LT(lit[0], 230);
  EXPECT_EQ(lit[3 * 50], 0);  // the background stays black
}

TEST(Exposure, TheLitMeterDoesNotDriftWithNoise) {
  // A progressive render's dark region is noisy: at few samples many of its pixels are black. A
  // meter that left out every black pixel would brighten the picture as it converges; the lit
  // meter counts a black pixel with a lit neighbour, so a noisy image of mean m meters as m.
  Image converged{64, 64, std::vector<float>(64 * 64 * 3, 0.1f)};
  Image noisy = converged;
  // Every other pixel black, the rest twice as bright: the same mean.
  for (size_t k = 0; k < 64 * 64; ++k)
    for (int c = 0; c < 3; ++c) noisy.rgb[3 * k + c] = (k + k / 64) % 2 ? 0.2f : 0.0f;
  EXPECT_NEAR(litExposureScale(noisy), litExposureScale(converged), 1e-6 * litExposureScale(converged));
}

TEST(ImageFiles, ExrRoundTripKeepsEveryBitAndTheHeader) {
  test::TempDir dir;
  Image image{5, 3, {}};
  std::mt19937 rng(11);
  std::exponential_distribution<float> radiance(0.1f);
  for (int k = 0; k < 45; ++k) image.rgb.push_back(radiance(rng));
  image.rgb[4] = 1e30f;  // beyond half precision: EXR stays float32
  ImageMetadata m;
  m.samplesPerPixel = 1234;
  m.totalSamples = 1234ull * 15;
  m.renderSeconds = 12.5;
  m.sceneHash = "abc123";
  m.rendererVersion = "v-test";
  m.extra["integrator"] = "naive";
  writeExr(dir / "x.exr", image, m);
  ImageMetadata back;
  const Image read = readExr(dir / "x.exr", &back);
  EXPECT_EQ(read.width, 5);
  EXPECT_EQ(read.height, 3);
  EXPECT_EQ(read.rgb, image.rgb);
  EXPECT_EQ(back.samplesPerPixel, 1234u);
  EXPECT_EQ(back.totalSamples, 1234ull * 15);
  EXPECT_EQ(back.renderSeconds, 12.5);
  EXPECT_EQ(back.sceneHash, "abc123");
  EXPECT_EQ(back.rendererVersion, "v-test");
  EXPECT_EQ(back.extra.at("integrator"), "naive");
}

TEST(ImageFiles, FailedWritesLeaveNoFileBehind) {
  test::TempDir dir;
  Image image{2, 2, std::vector<float>(12, 1.0f)};
  EXPECT_THROW(writeExr(dir / "missing-dir" / "x.exr", image, {}), InputError);
  EXPECT_THROW(writeImageFile(dir / "x.tiff", image, {}, {}), InputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
  writePng(dir / "p.png", image, {});
  EXPECT_TRUE(std::filesystem::exists(dir / "p.png"));
  size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1u) << "no temporary file may remain";
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

TEST(ImageDownscale, AveragesBoxesAndKeepsTheMean) {
  Image image{5, 4, {}};
  for (int k = 0; k < 5 * 4 * 3; ++k) image.rgb.push_back(float(k % 7));
  const Image small = downscaleToFit(image, 3);  // factor 2: 3 x 2
  ASSERT_EQ(small.width, 3);
  ASSERT_EQ(small.height, 2);
  // Top-left output pixel: the mean of input pixels (0,0), (1,0), (0,1), (1,1), red channel.
  const float expected = (image.at(0, 0).r + image.at(1, 0).r + image.at(0, 1).r + image.at(1, 1).r) / 4.0f;
  EXPECT_FLOAT_EQ(small.at(0, 0).r, expected);
  // The right column covers only input column 4.
  EXPECT_FLOAT_EQ(small.at(2, 0).g, (image.at(4, 0).g + image.at(4, 1).g) / 2.0f);
  EXPECT_EQ(downscaleToFit(image, 5).rgb, image.rgb) << "an image that fits is unchanged";
}

}  // namespace
}  // namespace lensfarm
