// `lensfarm denoise` through the real binary: the output keeps the raw beauty as the layer "noisy"
// bit for bit and is marked lensfarm/denoised in its header; a file without the guide layers is
// refused (exit 2, naming them and the --aov that makes them) unless --no-guides; an unreadable
// input or a non-EXR output is one line and exit 2, and nothing is written.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "common/film/image_io.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;

constexpr const char* kDenoisedNote = "a-trous (Dammertz 2010), 5 iterations, guided by albedo, normal, variance";

// A 32x24 noisy grey render (0.25 +- 10 %) with the layers `layers` among albedo, normal, variance.
Image noisyRender(const std::vector<std::string>& layers) {
  const int w = 32, h = 24;
  std::mt19937 rng(5);
  std::normal_distribution<float> gauss(0.25f, 0.025f);
  Image image(w, h, std::vector<float>(size_t(3 * w * h)));
  for (float& v : image.rgb) v = gauss(rng);
  for (const std::string& name : layers) {
    if (name == "albedo")
      image.layers.push_back({"albedo", {"R", "G", "B"}, std::vector<float>(image.rgb.size(), 0.5f)});
    if (name == "normal") {
      ImageLayer normal{"normal", {"X", "Y", "Z"}, std::vector<float>(image.rgb.size(), 0.0f)};
      for (size_t k = 2; k < normal.values.size(); k += 3) normal.values[k] = 1.0f;
      image.layers.push_back(normal);
    }
    if (name == "variance")
      image.layers.push_back({"variance", {"R", "G", "B"}, std::vector<float>(image.rgb.size(), 0.025f * 0.025f)});
  }
  return image;
}

fs::path writeRender(const test::TempDir& dir, const std::string& name, const Image& image) {
  ImageMetadata meta;
  meta.samplesPerPixel = 16;
  meta.sceneHash = "abc123";
  meta.extra["scene"] = "grey.json";
  writeExr(dir / name, image, meta);
  return dir / name;
}

test::ProcessResult denoiseCli(const std::vector<std::string>& args) {
  std::vector<std::string> argv{test::cliPath().string(), "denoise"};
  argv.insert(argv.end(), args.begin(), args.end());
  return test::runProcess(argv, 60);
}

TEST(CliDenoise, WritesTheDenoisedImageWithTheRawBeautyAsLayerNoisyAndMarksItsHeader) {
  test::TempDir dir;
  const Image input = noisyRender({"albedo", "normal", "variance"});
  const fs::path in = writeRender(dir, "in.exr", input), out = dir / "out.exr", png = dir / "out.png";
  const auto r = denoiseCli({in.string(), "-o", out.string(), "--png", png.string()});
  ASSERT_EQ(r.exitCode, 0) << r.out << r.err;
  EXPECT_TRUE(contains(r.out, "guided by albedo, normal, variance")) << r.out;
  EXPECT_TRUE(fs::exists(png));

  ImageMetadata meta;
  const Image result = readExr(out, &meta);
  EXPECT_EQ(meta.extra["denoised"], kDenoisedNote);
  EXPECT_EQ(meta.extra["scene"], "grey.json") << "the input's attributes are kept";
  EXPECT_EQ(meta.samplesPerPixel, 16u);
  EXPECT_EQ(meta.sceneHash, "abc123");
  const ImageLayer* raw = result.layer("noisy");
  ASSERT_NE(raw, nullptr);
  EXPECT_EQ(raw->values, input.rgb) << "the raw beauty, bit for bit";
  for (const char* name : {"albedo", "normal", "variance"}) EXPECT_NE(result.layer(name), nullptr) << name;
  // It did denoise: the spread around 0.25 is far smaller.
  const auto spread = [](const std::vector<float>& v) {
    double s = 0.0;
    for (float x : v) s += (x - 0.25) * (x - 0.25);
    return std::sqrt(s / double(v.size()));
  };
  EXPECT_LT(spread(result.rgb), spread(input.rgb) / 4);
}

TEST(CliDenoise, AFileWithoutTheGuideLayersIsRefusedUnlessNoGuidesIsGiven) {
  test::TempDir dir;
  const fs::path albedoOnly = writeRender(dir, "albedo.exr", noisyRender({"albedo"}));
  const fs::path bare = writeRender(dir, "bare.exr", noisyRender({}));
  const fs::path out = dir / "out.exr";

  const auto refused = denoiseCli({albedoOnly.string(), "-o", out.string()});
  EXPECT_EQ(refused.exitCode, test::kBadInput) << refused.err;
  EXPECT_TRUE(contains(
      refused.err,
      "lensfarm: error: " + albedoOnly.string() +
          ": has no normal, variance layers to guide the denoiser: render it with --aov albedo,normal,variance"))
      << refused.err;
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  EXPECT_FALSE(fs::exists(out)) << "nothing written";

  const auto bareRefused = denoiseCli({bare.string(), "-o", out.string()});
  EXPECT_EQ(bareRefused.exitCode, test::kBadInput);
  EXPECT_TRUE(contains(bareRefused.err, "has no albedo, normal, variance layers")) << bareRefused.err;

  const auto fallback = denoiseCli({bare.string(), "-o", out.string(), "--no-guides"});
  ASSERT_EQ(fallback.exitCode, 0) << fallback.err;
  ImageMetadata meta;
  const Image result = readExr(out, &meta);
  EXPECT_TRUE(contains(meta.extra["denoised"], "guided by colour only")) << meta.extra["denoised"];
  EXPECT_EQ(result.layer("noisy")->values, noisyRender({}).rgb);
  EXPECT_NE(result.rgb, noisyRender({}).rgb);
}

TEST(CliDenoise, BadFilesAndPathsExitTwoWithOneLineNamingThem) {
  test::TempDir dir;
  const std::string good = writeRender(dir, "in.exr", noisyRender({"albedo", "normal", "variance"})).string();
  const std::string missing = (dir / "missing.exr").string();
  const std::string text = dir.write("notes.exr", "not an image\n").string();
  const std::string out = (dir / "out.exr").string();
  struct Case {
    std::vector<std::string> args;
    std::string mustSay;  // after "lensfarm: error: "
  };
  for (const Case& c : std::vector<Case>{
           {{missing, "-o", out}, missing + ": cannot read EXR"},
           {{text, "-o", out}, text + ": cannot read EXR"},
           {{good, "-o", (dir / "out.png").string()},
            (dir / "out.png").string() + ": the denoised image must be an .exr"},
           {{good, "-o", out, "--png", (dir / "p.jpg").string()},
            (dir / "p.jpg").string() + ": the --png preview must be a .png"},
           {{good, "-o", out, "--strength", "0"}, "--strength: must be more than 0"},
       }) {
    const auto r = denoiseCli(c.args);
    EXPECT_EQ(r.exitCode, test::kBadInput) << c.mustSay << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "lensfarm: error: " + c.mustSay)) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

}  // namespace
}  // namespace lensfarm
