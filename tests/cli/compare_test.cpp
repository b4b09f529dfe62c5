// `lensfarm compare` through the real binary: exit 0 when the relative RMSE is within the
// tolerance, 1 beyond it, 2 with one line on stderr when the two images cannot be compared.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;

// An 8x4 image of `level` everywhere, each value moved by +delta and -delta in turn: its RMSE
// against the constant image is delta, its mean level (powers of two: exact in float).
Image alternating(float level, float delta) {
  Image image{8, 4, std::vector<float>(8 * 4 * 3, level)};
  for (size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] += k % 2 ? -delta : delta;
  return image;
}

fs::path writeImage(const test::TempDir& dir, const std::string& name, const Image& image) {
  ImageMetadata meta;
  meta.samplesPerPixel = 16;
  writeExr(dir / name, image, meta);
  return dir / name;
}

test::ProcessResult compare(const std::vector<std::string>& args) {
  std::vector<std::string> argv{test::cliPath().string(), "compare"};
  argv.insert(argv.end(), args.begin(), args.end());
  return test::runProcess(argv, 60);
}

TEST(CliCompare, ExitsZeroWithinTheToleranceAndOneBeyondIt) {
  test::TempDir dir;
  const std::string ref = writeImage(dir, "ref.exr", alternating(2.0f, 0.0f)).string();
  const std::string close = writeImage(dir, "close.exr", alternating(2.0f, 0.0625f)).string();  // 3.125 %
  const std::string far = writeImage(dir, "far.exr", alternating(2.0f, 0.1875f)).string();      // 9.375 %

  const auto same = compare({ref, ref, "--tolerance", "0"});
  EXPECT_EQ(same.exitCode, 0) << same.out << same.err;
  EXPECT_TRUE(contains(same.out, "verdict:           agree (relative RMSE 0 <= tolerance 0)\n")) << same.out;

  const auto within = compare({close, ref});  // the default tolerance, 0.05
  EXPECT_EQ(within.exitCode, 0) << within.out << within.err;
  EXPECT_TRUE(contains(within.out, "relative RMSE:     0.03125  (RMSE / mean of the reference)\n")) << within.out;
  EXPECT_TRUE(contains(within.out, "verdict:           agree (relative RMSE 0.03125 <= tolerance 0.05)\n"))
      << within.out;
  EXPECT_EQ(within.err, "");

  const auto tighter = compare({close, ref, "--tolerance", "0.02"});
  EXPECT_EQ(tighter.exitCode, 1) << tighter.out << tighter.err;
  EXPECT_TRUE(contains(tighter.out, "verdict:           differ (relative RMSE 0.03125 > tolerance 0.02)\n"))
      << tighter.out;

  const auto beyond = compare({far, ref});
  EXPECT_EQ(beyond.exitCode, 1) << beyond.out << beyond.err;
  EXPECT_TRUE(contains(beyond.out, "verdict:           differ (relative RMSE 0.09375 > tolerance 0.05)\n"))
      << beyond.out;
  EXPECT_EQ(beyond.err, "") << "a verdict, not an error";

  const auto looser = compare({far, ref, "--tolerance", "0.1"});
  EXPECT_EQ(looser.exitCode, 0) << looser.out << looser.err;
}

TEST(CliCompare, ImagesThatCannotBeComparedExitTwoWithOneLineNamingTheCause) {
  test::TempDir dir;
  const std::string ref = writeImage(dir, "ref.exr", alternating(2.0f, 0.0f)).string();
  const std::string image = writeImage(dir, "image.exr", alternating(2.0f, 0.0625f)).string();
  Image wide{16, 4, std::vector<float>(16 * 4 * 3, 2.0f)};
  const std::string other = writeImage(dir, "wide.exr", wide).string();
  const std::string black = writeImage(dir, "black.exr", alternating(0.0f, 0.0f)).string();
  Image holed = alternating(2.0f, 0.0f);
  holed.rgb[3 * (8 * 2 + 5) + 1] = std::numeric_limits<float>::quiet_NaN();
  const std::string nan = writeImage(dir, "nan.exr", holed).string();
  const std::string text = dir.write("notes.exr", "not an image\n").string();
  const std::string missing = (dir / "missing.exr").string();

  struct Case {
    std::vector<std::string> args;
    std::string mustSay;  // after "lensfarm: error: "
  };
  for (const Case& c : std::vector<Case>{
           {{missing, ref}, missing + ": cannot read EXR"},
           {{image, text}, text + ": cannot read EXR"},
           {{other, ref}, other + ": is 16x4, the reference 8x4"},
           {{image, black}, black + ": is black (its mean is 0): a relative error against it is undefined"},
           {{nan, ref}, nan + ": pixel (5, 2) is not a finite number"},
           {{image, ref, "--tolerance", "-0.1"}, "--tolerance: must be 0 or more, got -0.1"},
           {{image, ref, "--tolerance", "nan"}, "--tolerance: expected a number, got \"nan\""},
       }) {
    const auto r = compare(c.args);
    EXPECT_EQ(r.exitCode, test::kBadInput) << c.mustSay << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "lensfarm: error: " + c.mustSay)) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(r.out, "") << "no measures, no verdict";
  }
}

}  // namespace
}  // namespace lensfarm
