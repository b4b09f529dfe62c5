// The à-trous denoiser (film/denoiser.h) on synthetic images whose truth is known: a noisy flat
// region comes back unbiased and much less noisy, albedo and normal edges stay sharp where a plain
// filter blurs them, a converged image comes back unchanged, fireflies and zeros give finite
// pixels, and the bits do not depend on the thread count.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <random>

#include "common/film/denoiser.h"

namespace lensfarm {
namespace {

struct Pixel {
  float irradiance[3];  // beauty = albedo x irradiance
  float albedo[3];
  float normal[3];
  float relativeSigma;  // noise standard deviation / beauty value
};

// An image with albedo, normal and variance layers, its pixels from `at(x, y)`: the beauty is
// albedo x irradiance plus Gaussian noise of the given relative standard deviation, the variance
// layer that noise's exact variance. `truth`, if given, gets the noise-free beauty.
Image syntheticImage(int w, int h, const std::function<Pixel(int, int)>& at, uint32_t seed,
                     std::vector<float>* truth = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  Image image(w, h, std::vector<float>(size_t(3 * w * h)));
  ImageLayer albedo{"albedo", {"R", "G", "B"}, {}}, normal{"normal", {"X", "Y", "Z"}, {}},
      variance{"variance", {"R", "G", "B"}, {}};
  if (truth) truth->assign(image.rgb.size(), 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Pixel p = at(x, y);
      const size_t k = 3 * (size_t(y) * size_t(w) + size_t(x));
      for (int c = 0; c < 3; ++c) {
        const float value = p.albedo[c] * p.irradiance[c];
        const float sigma = p.relativeSigma * value;
        image.rgb[k + size_t(c)] = value + sigma * gauss(rng);
        if (truth) (*truth)[k + size_t(c)] = value;
        albedo.values.push_back(p.albedo[c]);
        normal.values.push_back(p.normal[c]);
        variance.values.push_back(sigma * sigma);
      }
    }
  image.layers = {albedo, normal, variance};
  return image;
}

double rmse(const std::vector<float>& a, const std::vector<float>& b) {
  double sum = 0.0;
  for (size_t k = 0; k < a.size(); ++k) sum += (double(a[k]) - b[k]) * (double(a[k]) - b[k]);
  return std::sqrt(sum / double(a.size()));
}

// The 10-90 % width, in pixels, of a step along x: the mean over rows and channels of each column,
// the plateaus the means of the first and last `plateau` columns, the crossings linearly
// interpolated between columns.
double edgeWidth(const Image& image, int plateau = 8) {
  std::vector<double> profile(size_t(image.width), 0.0);
  for (int x = 0; x < image.width; ++x) {
    for (int y = 0; y < image.height; ++y)
      for (int c = 0; c < 3; ++c) profile[size_t(x)] += image.rgb[3 * (size_t(y) * image.width + x) + size_t(c)];
    profile[size_t(x)] /= 3.0 * image.height;
  }
  double low = 0.0, high = 0.0;
  for (int x = 0; x < plateau; ++x) {
    low += profile[size_t(x)] / plateau;
    high += profile[size_t(image.width - 1 - x)] / plateau;
  }
  const auto crossing = [&](double fraction) {
    const double level = low + fraction * (high - low);
    for (int x = 0; x + 1 < image.width; ++x) {
      const double a = profile[size_t(x)], b = profile[size_t(x + 1)];
      if ((a - level) * (b - level) <= 0.0 && a != b) return x + (level - a) / (b - a);
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  return std::abs(crossing(0.9) - crossing(0.1));
}

// A plain (unguided) box filter of radius r: what the edge-stopping weights are there to beat.
Image boxFiltered(const Image& image, int r) {
  Image out = image;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        double sum = 0.0;
        int n = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx) {
            const int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= image.width || qy >= image.height) continue;
            sum += image.rgb[3 * (size_t(qy) * image.width + qx) + size_t(c)];
            ++n;
          }
        out.rgb[3 * (size_t(y) * image.width + x) + size_t(c)] = float(sum / n);
      }
  return out;
}

Pixel flat(float value, float relativeSigma) {
  // albedo 0.5, so the irradiance is twice the beauty's value
  return {{2 * value, 2 * value, 2 * value}, {0.5f, 0.5f, 0.5f}, {0, 0, 1}, relativeSigma};
}

TEST(Denoiser, AFlatRegionKeepsItsValueAndLosesMostOfItsNoise) {
  for (const float relativeSigma : {0.1f, 0.3f}) {
    std::vector<float> truth;
    const Image noisy = syntheticImage(
        64, 64, [&](int, int) { return flat(0.3f, relativeSigma); }, 7, &truth);
    const Image denoised = denoise(noisy);
    double mean = 0.0;
    for (float v : denoised.rgb) mean += v;
    mean /= double(denoised.rgb.size());
    const double before = rmse(noisy.rgb, truth), after = rmse(denoised.rgb, truth);
    std::printf("flat 0.3, noise %.0f %%: mean %.6f (%+.3f %%), RMSE %.5f -> %.5f (%.1fx lower)\n", 100 * relativeSigma,
                mean, 100 * (mean / 0.3 - 1), before, after, before / after);
    EXPECT_NEAR(mean, 0.3, 0.005 * 0.3) << "no bias on a flat region";
    EXPECT_GE(before / after, 4.0) << "RMSE " << before << " -> " << after;
  }
}

// Monte Carlo pixels are skewed (most samples dark, a few bright): an edge-stopping weight prefers
// neighbours close to the centre, so a skewed flat region comes back darker. The colour weight's
// first level compares 3x3 neighbourhoods to keep that small; these bounds are the ones
// docs/aovs.md gives.
TEST(Denoiser, AFlatRegionWithSkewedNoiseIsBiasedLowByLittle) {
  struct Case {
    float shape;   // of the gamma distribution of the pixel values: relative sigma 1 / sqrt(shape)
    double bound;  // on |denoised mean / noisy mean - 1|
  };
  for (const Case c : {Case{4.0f, 0.006}, Case{1.0f, 0.025}}) {
    std::mt19937 rng(9);
    std::gamma_distribution<float> gamma(c.shape, 0.3f / c.shape);  // mean 0.3
    Image noisy = syntheticImage(
        128, 128, [&](int, int) { return flat(0.3f, 0.0f); }, 9);
    for (float& v : noisy.rgb) v = gamma(rng);
    for (float& v : noisy.layers[2].values) v = 0.09f / c.shape;
    const std::vector<float> truth(noisy.rgb.size(), 0.3f);
    const Image denoised = denoise(noisy);
    double noisyMean = 0.0, mean = 0.0;
    for (size_t k = 0; k < noisy.rgb.size(); ++k) {
      noisyMean += noisy.rgb[k];
      mean += denoised.rgb[k];
    }
    const double bias = mean / noisyMean - 1;
    std::printf("flat 0.3, gamma noise of relative sigma %.0f %%: bias %+.2f %%, RMSE %.4f -> %.4f\n",
                100 / std::sqrt(c.shape), 100 * bias, rmse(noisy.rgb, truth), rmse(denoised.rgb, truth));
    EXPECT_LT(std::abs(bias), c.bound);
    EXPECT_GE(rmse(noisy.rgb, truth) / rmse(denoised.rgb, truth), 4.0);
  }
}

TEST(Denoiser, WithoutGuidesTheColourWeightAloneStillSmoothsAFlatRegion) {
  std::vector<float> truth;
  Image noisy = syntheticImage(
      64, 64, [](int, int) { return flat(0.3f, 0.1f); }, 8, &truth);
  DenoiseOptions options;
  options.useGuides = false;
  EXPECT_THROW(denoise(Image(64, 64, noisy.rgb)), std::invalid_argument) << "guides asked for, none there";
  const double before = rmse(noisy.rgb, truth);
  const double withVariance = rmse(denoise(noisy, options).rgb, truth);
  noisy.layers.erase(noisy.layers.begin(), noisy.layers.begin() + 2);  // albedo, normal
  EXPECT_EQ(missingDenoiseGuides(noisy), (std::vector<std::string>{"albedo", "normal"}));
  noisy.layers.clear();
  EXPECT_EQ(missingDenoiseGuides(noisy), (std::vector<std::string>{"albedo", "normal", "variance"}));
  const double colourOnly = rmse(denoise(noisy, options).rgb, truth);
  std::printf("no guides: RMSE %.5f -> %.5f (variance layer), %.5f (variance estimated)\n", before, withVariance,
              colourOnly);
  EXPECT_GE(before / withVariance, 4.0);
  EXPECT_GE(before / colourOnly, 2.0);
}

TEST(Denoiser, AnEdgeBetweenTwoAlbedosStaysSharpWhereABoxFilterBlursIt) {
  const Image noisy = syntheticImage(
      64, 32,
      [](int x, int) {
        const float a = x < 32 ? 0.2f : 0.8f;
        return Pixel{{1, 1, 1}, {a, a, a}, {0, 0, 1}, 0.5f};
      },
      11);
  DenoiseOptions colourOnly;
  colourOnly.useGuides = false;
  const double denoised = edgeWidth(denoise(noisy)), box = edgeWidth(boxFiltered(noisy, 2));
  const double unguided = edgeWidth(denoise(noisy, colourOnly));
  std::printf(
      "albedo edge 0.2 | 0.8, 50 %% noise, 10-90 %% width: noisy %.2f px, denoised %.2f px, 5x5 box %.2f px, denoised "
      "without guides %.2f px\n",
      edgeWidth(noisy), denoised, box, unguided);
  EXPECT_LE(denoised, 1.5);
  EXPECT_GT(box, 2.5) << "the plain filter of the kernel's first-level support blurs it";
  EXPECT_GT(unguided, 1.25) << "the colour weight alone blurs it at this noise";
}

TEST(Denoiser, AnEdgeWhereTwoWallsMeetStaysSharpByTheNormalWeight) {
  // Same albedo, irradiance 0.8 | 1.0 and 20 % noise: the step is one standard deviation of the
  // noise, too little for the colour weight to see; only the normals tell the walls apart.
  const Image noisy = syntheticImage(
      64, 32,
      [](int x, int) {
        const bool left = x < 32;
        const float e = left ? 0.8f : 1.0f;
        return Pixel{{e, e, e}, {0.5f, 0.5f, 0.5f}, {left ? 1.0f : 0.0f, 0, left ? 0.0f : 1.0f}, 0.2f};
      },
      12);
  DenoiseOptions noNormals;
  noNormals.sigmaNormal = 0.0;  // w_normal = 1 everywhere
  const double denoised = edgeWidth(denoise(noisy)), blind = edgeWidth(denoise(noisy, noNormals));
  std::printf("normal edge (90 degrees), 10-90 %% width: denoised %.2f px, without the normal weight %.2f px\n",
              denoised, blind);
  EXPECT_LE(denoised, 1.5);
  EXPECT_GT(blind, 2.5) << "without the normals the same filter blurs the edge";
}

// A textured image with walls and noise, for the tests below.
Image busyImage(float relativeSigma, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.05f, 1.0f);
  std::vector<Pixel> pixels;
  for (int k = 0; k < 48 * 40; ++k) {
    const int x = k % 48;
    const float a = u(rng), e = x < 20 ? 0.5f : 1.5f;
    pixels.push_back(
        {{e * u(rng), e, e}, {a, a * 0.5f, x % 7 == 0 ? 0.0f : a}, {x < 20 ? 1.0f : 0.0f, 0, 1}, relativeSigma});
  }
  return syntheticImage(
      48, 40, [&](int x, int y) { return pixels[size_t(y * 48 + x)]; }, seed);
}

TEST(Denoiser, TheBitsDoNotDependOnTheThreadCount) {
  const Image noisy = busyImage(0.3f, 21);
  Image one, two;
  tbb::task_arena(1).execute([&] { one = denoise(noisy); });
  tbb::task_arena(2).execute([&] { two = denoise(noisy); });
  ASSERT_EQ(one.rgb.size(), two.rgb.size());
  EXPECT_EQ(0, std::memcmp(one.rgb.data(), two.rgb.data(), one.rgb.size() * sizeof(float)));
  EXPECT_NE(one.rgb, noisy.rgb) << "it did filter";
}

TEST(Denoiser, AConvergedImageComesBackUnchanged) {
  const Image converged = busyImage(0.0f, 22);  // variance 0 everywhere
  const Image out = denoise(converged);
  for (size_t k = 0; k < out.rgb.size(); ++k)
    ASSERT_LE(std::abs(out.rgb[k] - converged.rgb[k]), 1e-6 * std::abs(converged.rgb[k])) << "value " << k;
}

TEST(Denoiser, KeepsEveryLayerAndTheRawBeautyAsTheLayerNoisy) {
  const Image noisy = busyImage(0.2f, 23);
  const Image out = denoise(noisy);
  ASSERT_EQ(out.layers.size(), noisy.layers.size() + 1);
  for (size_t i = 0; i < noisy.layers.size(); ++i) {
    EXPECT_EQ(out.layers[i].name, noisy.layers[i].name);
    EXPECT_EQ(out.layers[i].values, noisy.layers[i].values);
  }
  const ImageLayer* raw = out.layer("noisy");
  ASSERT_NE(raw, nullptr);
  EXPECT_EQ(raw->channels, (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_EQ(raw->values, noisy.rgb);
  // A second pass keeps the first raw image, not the once-denoised one.
  const Image twice = denoise(out);
  EXPECT_EQ(twice.layers.size(), out.layers.size());
  EXPECT_EQ(twice.layer("noisy")->values, noisy.rgb);
}

TEST(Denoiser, FirefliesZerosAndNonFiniteInputGiveFiniteOutput) {
  Image fireflies = busyImage(0.3f, 24);
  ImageLayer& variance = fireflies.layers[2];
  const size_t a = 3 * (10 * 48 + 30), b = 3 * (25 * 48 + 5), nan = 3 * (30 * 48 + 40);
  for (int c = 0; c < 3; ++c) {
    fireflies.rgb[a + size_t(c)] = 1e30f;  // a huge sample, with the variance it would bring
    variance.values[a + size_t(c)] = 1e36f;
    fireflies.rgb[b + size_t(c)] = 3e38f;  // near the float limit, with no variance
    variance.values[b + size_t(c)] = 0.0f;
  }
  fireflies.rgb[nan + 1] = std::numeric_limits<float>::quiet_NaN();
  const Image out = denoise(fireflies);
  for (size_t k = 0; k < out.rgb.size(); ++k)
    if (k / 3 != nan / 3) {
      ASSERT_TRUE(std::isfinite(out.rgb[k])) << "value " << k;
    }
  EXPECT_TRUE(std::isnan(out.rgb[nan + 1])) << "a NaN pixel is kept as it is, and does not spread";

  Image zeros(16, 16, std::vector<float>(16 * 16 * 3, 0.0f));
  zeros.layers = {{"albedo", {"R", "G", "B"}, std::vector<float>(16 * 16 * 3, 0.0f)},
                  {"normal", {"X", "Y", "Z"}, std::vector<float>(16 * 16 * 3, 0.0f)},
                  {"variance", {"R", "G", "B"}, std::vector<float>(16 * 16 * 3, 0.0f)}};
  EXPECT_EQ(denoise(zeros).rgb, zeros.rgb);
  DenoiseOptions colourOnly;
  colourOnly.useGuides = false;
  zeros.layers.clear();
  EXPECT_EQ(denoise(zeros, colourOnly).rgb, zeros.rgb);
}

}  // namespace
}  // namespace lensfarm
