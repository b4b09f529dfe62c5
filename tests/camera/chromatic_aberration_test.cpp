// Chromatic aberration through a real lens (the requirement: "colour fringes whose width
// matches the lens's computed lateral colour within 10 %"). A small white emitter near the edge
// of the field is rendered through a lens whose glass disperses (every camera sample at its own
// wavelength, camera/spectral_response.h); its red and blue images lie apart on the sensor by
// what lateralColour (camera/lens_analysis.h) computes by tracing the lens, an estimate that
// shares no code with the renderer's camera rays (object side, at fixed wavelengths, pupil grid
// against image side, random wavelengths, exit-pupil bounds). Through a lens that barely
// disperses (still spectral) they coincide, and a white field stays white: the RGB -> spectrum
// -> sensor round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/camera/lens_analysis.h"
#include "common/camera/real_lens_camera.h"
#include "common/camera/spectral_response.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

constexpr double kSensorWidthMm = 36.0;
// A strip of the 36 mm frame through the emitter (0.1 mm cells), so that the samples go where
// its image is.
constexpr int kWidth = 360, kHeight = 60;
constexpr double kDistanceMm = 2000.0;  // the emitter's and the focus's distance from the front vertex
// The emitter: 80 mm square at 2 m, an image 2 mm across (+-1.1 degrees of field). Over so little
// field the lateral colour changes linearly, so the image's centroid is its centre's; and a
// source larger than the blur leaves most cells fully lit, so its centroids converge fast (four
// seeds: 0.2545 to 0.2635 mm against the computed 0.2588 mm).
constexpr double kEmitterMm = 80.0;

// A dense-flint singlet (SF11: n_d 1.78472, V_d 25.68, Schott) 15 mm behind its stop, f = 50 mm:
// the textbook lens with lateral colour (the chief ray crosses it off centre, so its
// magnification changes with the index). `abbe` 0: no dispersion.
std::string singlet(double abbe) {
  const std::string v = abbe > 0.0 ? "\t" + std::to_string(abbe) : "";
  return "# a stop, then a biconvex SF11 singlet\n"
         "0\t15\t0\t10\n"
         "78.472\t6\t1.78472\t36" +
         v + "\n-78.472\t0\t1\t36\n";
}

json emitterScene(const std::string& lensFile, double xMm, double sizeMm, int spp) {
  const double x = xMm / 1000.0, z = kDistanceMm / 1000.0, s = sizeMm / 1000.0;
  return json{
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "real_lens"},
        {"lens", lensFile},
        {"position", {0, 0, 0}},
        {"look_at", {0, 0, 1}},
        {"up", {0, 1, 0}},
        {"sensor_width", kSensorWidthMm / 1000.0},
        {"scene_units_per_mm", 0.001},
        {"focus_distance", z}}},
      {"materials", {{"white", {{"type", "emissive"}, {"radiance", 1.0}, {"two_sided", true}}}}},
      {"shapes",
       {{{"type", "quad"},
         {"corner", {x - s / 2, -s / 2, z}},
         {"edge1", {s, 0, 0}},
         {"edge2", {0, s, 0}},
         {"material", "white"}}}},
      {"render", {{"resolution", {kWidth, kHeight}}, {"samples_per_pixel", spp}, {"max_bounces", 1}, {"seed", 11}}}};
}

// Each channel's image centroid, as the distance from the image's centre along x, in mm.
struct Centroids {
  double radial[3] = {0, 0, 0};
  double flux[3] = {0, 0, 0};
};
Centroids centroidsOf(const Image& image) {
  Centroids c;
  double moment[3] = {0, 0, 0};
  const double pitch = kSensorWidthMm / image.width;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int ch = 0; ch < 3; ++ch) {
        const double v = image.rgb[3 * (size_t(y) * image.width + x) + ch];
        c.flux[ch] += v;
        moment[ch] += v * std::abs((x + 0.5 - image.width / 2.0) * pitch);
      }
  for (int ch = 0; ch < 3; ++ch) c.radial[ch] = moment[ch] / c.flux[ch];
  return c;
}

struct EmitterSetup {
  test::TempDir dir;
  Scene scene;
  LateralColour computed;
};

// The emitter at `fieldDegrees` from the entrance pupil's centre, and the lens's lateral colour
// for it on the camera's film.
void prepare(EmitterSetup& s, const std::string& lensText, double fieldDegrees, int spp) {
  const std::string file = s.dir.write("lens.dat", lensText).string();
  const LensSystem lens = LensSystem::parsePbrt(lensText, "lens.dat");
  const double x = (kDistanceMm + lens.paraxial().entrancePupilZ) * std::tan(fieldDegrees * M_PI / 180.0);
  s.scene = test::loadSceneJson(s.dir, emitterScene(file, x, kEmitterMm, spp));
  s.computed = lateralColour(lens, fieldDegrees, kDistanceMm, s.scene.realLensCamera()->filmZ());
}

TEST(ChromaticAberration, TheFringeBetweenRedAndBlueIsTheLensesLateralColour) {
  EmitterSetup s;
  prepare(s, singlet(25.68), 15.0, 384);
  const test::Rendered r = test::renderScene(s.scene);
  const Centroids c = centroidsOf(r.image);
  const double measured = c.radial[0] - c.radial[2];
  std::printf(
      "lateral colour: computed %.4f mm (red %.4f, green %.4f, blue %.4f), rendered %.4f mm (red %.4f, "
      "green %.4f, blue %.4f)\n",
      s.computed.lateral, s.computed.heightRed, s.computed.heightGreen, s.computed.heightBlue, measured, c.radial[0],
      c.radial[1], c.radial[2]);
  ASSERT_GT(std::abs(s.computed.lateral), 0.1) << "a lateral colour of over a cell, for the test to see";
  EXPECT_NEAR(measured, s.computed.lateral, 0.1 * std::abs(s.computed.lateral));
  // Each channel's image where the lens puts it (the heights are the film's, the image inverted back).
  EXPECT_NEAR(c.radial[0], std::abs(s.computed.heightRed), 0.02);
  EXPECT_NEAR(c.radial[2], std::abs(s.computed.heightBlue), 0.02);
  EXPECT_EQ(r.stats.dropped, 0u);
}

TEST(ChromaticAberration, ALensThatBarelyDispersesKeepsTheChannelsTogetherAndWhiteWhite) {
  // V_d = 10^6: spectral camera samples, but every wavelength takes (nearly) the d line's ray.
  EmitterSetup s;
  prepare(s, singlet(1e6), 15.0, 96);
  ASSERT_TRUE(s.scene.realLensCamera()->spectral());
  EXPECT_LT(std::abs(s.computed.lateral), 1e-4);
  const Centroids c = centroidsOf(test::renderScene(s.scene).image);
  EXPECT_NEAR(c.radial[0], c.radial[2], 0.005);
  // The round trip: the same scene through the lens that does not disperse at all (RGB, traced
  // at the d line) has the same flux in every channel, which the spectral render matches.
  EmitterSetup rgb;
  prepare(rgb, singlet(0.0), 15.0, 96);
  ASSERT_FALSE(rgb.scene.realLensCamera()->spectral());
  const Centroids d = centroidsOf(test::renderScene(rgb.scene).image);
  EXPECT_EQ(d.flux[0], d.flux[2]);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c.flux[ch], d.flux[ch], 0.03 * d.flux[ch]) << ch;
}

TEST(ChromaticAberration, AWhiteFieldThroughTheDoubleGaussStaysWhite) {
  // The library double-Gauss disperses (its glasses' Abbe numbers): a white wall filling the
  // view reads the same in every channel, up to noise.
  test::TempDir dir;
  json scene = emitterScene((test::scenesDir() / "lenses/dgauss.50mm.dat").string(), 0.0, 4000.0, 12);
  scene["render"]["resolution"] = {60, 40};
  const Scene loaded = test::loadSceneJson(dir, scene);
  ASSERT_TRUE(loaded.realLensCamera()->spectral());
  const test::Rendered r = test::renderScene(loaded);
  EXPECT_GT(r.mean[0], 0.5);
  EXPECT_NEAR(r.mean[0], r.mean[1], 0.01 * r.mean[1]);
  EXPECT_NEAR(r.mean[2], r.mean[1], 0.01 * r.mean[1]);
}

// The sensor's model (spectral_response.h): each response integrates to 1 over its band and to 0
// elsewhere, so reading a step spectrum returns its RGB; and the wavelength sampler covers the
// three bands once in every three consecutive samples, at a point uniform in its band.
TEST(SpectralResponse, TheRoundTripIsExactAndTheBandsAreStratified) {
  const double rgb[3] = {0.7, 0.2, 0.05};
  for (int c = 0; c < 3; ++c) {
    double reading = 0.0, area = 0.0;
    const int n = 3000;  // midpoints of 0.1 nm steps over 400..700 nm
    for (int k = 0; k < n; ++k) {
      const double nm = 400.0 + 300.0 * (k + 0.5) / n;
      int band = 0;
      while (nm >= spectral::kBandEdges[band + 1]) ++band;
      const double step = rgb[spectral::channelOfBand(band)];
      reading += spectral::response(c, nm) * step * 0.1;
      area += spectral::response(c, nm) * 0.1;
    }
    EXPECT_NEAR(area, 1.0, 1e-9) << c;
    EXPECT_NEAR(reading, rgb[c], 1e-9) << c;
  }
  for (const float uPixel : {0.1f, 0.5f, 0.9f}) {
    int seen[3] = {0, 0, 0};
    double sumPosition[3] = {0, 0, 0};
    const int n = 3000;
    for (uint64_t s = 0; s < uint64_t(n); ++s) {
      const float u = (float(s) + 0.5f) / float(n);
      const spectral::WavelengthSample w = spectral::sampleWavelength(s, uPixel, u);
      const int band = spectral::bandOfChannel(w.channel);
      ASSERT_GE(w.nm, spectral::kBandEdges[band]);
      ASSERT_LT(w.nm, spectral::kBandEdges[band + 1]);
      ++seen[w.channel];
      sumPosition[w.channel] +=
          (w.nm - spectral::kBandEdges[band]) / (spectral::kBandEdges[band + 1] - spectral::kBandEdges[band]);
      if (s % 3 == 2) {
        EXPECT_TRUE(seen[0] == seen[1] && seen[1] == seen[2]) << s;
      }
    }
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sumPosition[c] / seen[c], 0.5, 0.01) << c;
  }
}

}  // namespace
}  // namespace lensfarm
