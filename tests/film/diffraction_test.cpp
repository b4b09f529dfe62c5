// Diffraction by the aperture (film/diffraction_psf.h, film/psf_convolution.h), against
// independent figures: the Airy pattern's first dark ring at 1.22 lambda N and its 83.8 %
// encircled energy (Born & Wolf, "Principles of Optics", 8.5.2), the spike count of a bladed
// aperture (n spikes for an even blade count n, 2n for an odd one: each edge diffracts
// perpendicular to itself, and parallel edge pairs share their spikes), and the convolution's
// conservation of energy and its image of a single bright pixel.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

#include "common/film/diffraction_psf.h"
#include "common/film/psf_convolution.h"

namespace lensfarm {
namespace {

// The first local minimum of f along x > 0 (f sampled at `step`), by parabolic refinement.
double firstMinimum(const std::function<double(double)>& f, double step, double limit) {
  for (double x = 2 * step; x < limit; x += step) {
    const double a = f(x - step), b = f(x), c = f(x + step);
    if (b < a && b <= c) return x + 0.5 * step * (a - c) / (a - 2 * b + c);
  }
  return -1.0;
}

TEST(Diffraction, ARoundPupilsFirstDarkRingIsAt1_22LambdaN) {
  const FraunhoferPattern airy = fraunhoferPattern(0, 0.0, 1024, 8);
  // On the pattern's own samples (no interpolation): x in units of lambda N.
  const int n = airy.size;
  const auto alongX = [&](double x) {
    return airy.intensity[size_t(n / 2) * n + size_t(n / 2 + std::lround(x / airy.spacing))];
  };
  const double ring = firstMinimum(alongX, airy.spacing, 4.0);
  EXPECT_NEAR(ring, 1.22, airy.spacing) << "within one sample of the grid";
  // Diagonally too: the pattern is round.
  const double diagonal =
      firstMinimum([&](double r) { return airy.at(r / std::sqrt(2.0), r / std::sqrt(2.0)); }, 0.02, 4.0);
  EXPECT_NEAR(diagonal, 1.22, airy.spacing);
}

TEST(Diffraction, TheFirstDarkRingHolds83_8PercentOfTheEnergy) {
  const FraunhoferPattern airy = fraunhoferPattern(0, 0.0, 1024, 8);
  const int n = airy.size;
  const double radius = 1.2197 / airy.spacing;  // in samples
  double inside = 0.0;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c)
      if (std::hypot(r - n / 2, c - n / 2) <= radius) inside += airy.intensity[size_t(r) * n + c];
  EXPECT_NEAR(inside, 0.838, 0.02);
}

// The pixel kernel puts the ring where lambda and the working f-number say: f/16 at 550 nm,
// 1 um pixels, so the ring is 1.22 * 0.55 * 16 = 10.7 pixels out.
TEST(Diffraction, ThePixelKernelScalesWithLambdaAndTheFNumber) {
  const FraunhoferPattern airy = fraunhoferPattern(0, 0.0);
  DiffractionOptics optics;
  optics.workingFNumber = 16.0;
  optics.pixelWidthMm = optics.pixelHeightMm = 0.001;
  optics.width = optics.height = 600;                              // wide enough for the crop
  const DiffractionKernel k = diffractionKernel(airy, optics, 1);  // one wavelength a channel: 650, 550, 450 nm
  for (int c = 0; c < 3; ++c) {
    const double lambda = channelWavelengths(c, 1)[0];
    const double expected = airyRadiusMm(lambda, 16.0) / optics.pixelWidthMm;
    const double ring = firstMinimum([&](double x) { return k.at(c, int(std::lround(x)), 0); }, 1.0, 40.0);
    EXPECT_NEAR(ring, expected, 1.0) << "channel " << c << " at " << lambda << " nm";
  }
  EXPECT_GT(k.keptEnergy, 0.99);
  EXPECT_LE(k.keptEnergy, 1.0 + 1e-9);
  double sum = 0.0;
  for (double v : k.channel[1]) sum += v;
  EXPECT_NEAR(sum, 1.0, 1e-12);
}

// Spikes: the maxima of the pattern's angular profile between 6 and 60 lambda N, outside the
// central disk, where a polygon's edges put their streaks.
int spikes(int blades, double rotation) {
  const FraunhoferPattern p = fraunhoferPattern(blades, rotation);
  constexpr int kBins = 720;
  std::vector<double> profile(kBins, 0.0);
  for (int a = 0; a < kBins; ++a) {
    const double theta = 2.0 * std::numbers::pi * a / kBins;
    for (double r = 6.0; r < 60.0; r += 0.05) profile[size_t(a)] += r * p.at(r * std::cos(theta), r * std::sin(theta));
  }
  std::vector<double> sorted = profile;
  std::nth_element(sorted.begin(), sorted.begin() + kBins / 2, sorted.end());
  const double median = sorted[kBins / 2];
  // A spike: the largest bin within +-5 degrees, and 2.5 times the median (the 14 spikes of a
  // heptagon stand 4.5 times above it, the ripples of a round pupil's rings 1.0 times).
  int count = 0;
  for (int a = 0; a < kBins; ++a) {
    bool peak = profile[size_t(a)] > 2.5 * median;
    for (int d = -10; d <= 10 && peak; ++d)
      peak = d == 0 || profile[size_t(a)] > profile[size_t((a + d + kBins) % kBins)];
    count += peak;
  }
  return count;
}

TEST(Diffraction, AnEvenBladeCountGivesAsManySpikesAndAnOddOneTwice) {
  EXPECT_EQ(spikes(6, 0.0), 6);  // at 30, 90, ... degrees: perpendicular to the edges
  EXPECT_EQ(spikes(6, 0.3), 6);
  EXPECT_EQ(spikes(7, 0.0), 14);
  EXPECT_EQ(spikes(5, 0.2), 10);
  EXPECT_EQ(spikes(0, 0.0), 0) << "a round pupil has rings, no spikes";
}

DiffractionKernel hexagonKernel() {
  DiffractionOptics optics;
  optics.blades = 6;
  optics.workingFNumber = 8.0;
  optics.pixelWidthMm = optics.pixelHeightMm = 0.004;
  optics.width = optics.height = 40;
  return diffractionKernel(fraunhoferPattern(6, 0.0), optics, 2);
}

TEST(Diffraction, ConvolutionMapsABrightPixelToThePsf) {
  const DiffractionKernel k = hexagonKernel();
  ASSERT_GE(k.radius, 3);
  const int w = 2 * k.radius + 9, h = 2 * k.radius + 5, x0 = k.radius + 3, y0 = k.radius + 2;
  Image image{w, h, std::vector<float>(size_t(w) * h * 3, 0.0f)};
  for (int c = 0; c < 3; ++c) image.rgb[3 * (size_t(y0) * w + x0) + c] = 1.0f;
  convolveChannels(image, k);
  double worst = 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const int dx = x - x0, dy = y - y0;
        const double expected = std::abs(dx) <= k.radius && std::abs(dy) <= k.radius ? k.at(c, dx, dy) : 0.0;
        worst = std::max(worst, std::abs(image.rgb[3 * (size_t(y) * w + x) + c] - expected));
      }
  EXPECT_LT(worst, 1e-7);
}

TEST(Diffraction, ConvolutionConservesTheImagesEnergy) {
  const DiffractionKernel k = hexagonKernel();
  const int w = 2 * k.radius + 50, h = 2 * k.radius + 30;
  Image image{w, h, std::vector<float>(size_t(w) * h * 3, 0.0f)};
  uint32_t state = 12345u;
  double before[3] = {0, 0, 0};
  // Light only where the kernel keeps it in the frame, spanning six orders of magnitude.
  for (int y = k.radius; y < h - k.radius; ++y)
    for (int x = k.radius; x < w - k.radius; ++x)
      for (int c = 0; c < 3; ++c) {
        state = state * 1664525u + 1013904223u;
        const float v = float(std::pow(10.0, 6.0 * (state >> 8) / double(1u << 24) - 3.0));
        image.rgb[3 * (size_t(y) * w + x) + c] = v;
        before[c] += v;
      }
  const Image original = image;
  convolveChannels(image, k);
  EXPECT_NE(image.rgb, original.rgb);
  for (int c = 0; c < 3; ++c) {
    double after = 0.0;
    for (size_t p = 0; p < size_t(w) * h; ++p) after += image.rgb[3 * p + size_t(c)];
    EXPECT_NEAR(after / before[c], 1.0, 1e-6) << "channel " << c;
  }
}

TEST(Diffraction, WithoutAKernelTheImageIsUntouched) {
  Image image{3, 2, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18}};
  const Image original = image;
  applyDiffraction(nullptr, image);
  EXPECT_EQ(image.rgb, original.rgb);
}

}  // namespace
}  // namespace lensfarm
