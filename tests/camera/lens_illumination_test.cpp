// Relative illumination (camera/lens_analysis.h), computed from the object side (a beam's
// transmitted cross-section and the Jacobian from field angle to image height), against (a) the
// cos^4 law it must reduce to for a lens without distortion or vignetting, and (b) the render
// check: a render of a uniform white environment through the real-lens camera, whose pixels
// come from the image side (Kolb et al.'s weights over the exit pupil), falls off toward the
// corners as the computed relative illumination says, within 2 %.
#include <gtest/gtest.h>

#include <cmath>

#include "common/camera/lens_analysis.h"
#include "common/camera/real_lens_camera.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

TEST(RelativeIllumination, FollowsTheFisheyesEquidistantMappingAndVignetting) {
  // RI = V cos(theta) sin(theta) h'(0)^2 / (h h'): for the equidistant fisheye (h = f theta,
  // measured within 0.7 %: lens_projection_test.cpp) it is V cos(theta) sin(theta) / theta, and
  // for an undistorted lens V cos^4 -- the mapping's share of the fall-off, here checked against
  // the projection's formula rather than the measured h.
  const LensSystem fisheye =
      LensSystem::parsePbrt(test::readFile(test::scenesDir() / "lenses/fisheye.10mm.dat"), "fisheye.10mm.dat");
  for (const IlluminationPoint& p : relativeIllumination(fisheye, 72.0, 8, NAN, 256)) {
    const double t = p.angleDegrees * M_PI / 180.0;
    const double mapping = t > 0.0 ? std::cos(t) * std::sin(t) / t : 1.0;
    EXPECT_NEAR(p.relative, p.area * mapping, 0.02 * p.area * mapping) << p.angleDegrees;
    EXPECT_GT(p.area, 0.8) << "the fisheye hardly vignettes within 72 degrees";
  }
}

// The image of a uniform white environment (radiance 1, nothing in view) through `lensFile` at
// `fNumber`, compared ring by ring with the object-side relative illumination.
void expectRenderFollowsRelativeIllumination(const std::string& lensFile, double fNumber) {
  test::TempDir dir;
  const int width = 72, height = 48;
  const json scene = {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "real_lens"},
        {"lens", (test::scenesDir() / "lenses" / lensFile).string()},
        {"position", {0, 0, 0}},
        {"look_at", {0, 0, 1}},
        {"up", {0, 1, 0}},
        {"sensor_width", 0.036},
        {"sensor_height", 0.024},
        {"scene_units_per_mm", 0.001},
        {"focus_distance", 1000.0},
        {"f_number", fNumber}}},
      {"render", {{"resolution", {width, height}}, {"samples_per_pixel", 256}}},
      // One small quad behind the camera (a scene needs a triangle); the camera sees only sky.
      {"materials", {{"w", {{"type", "lambertian"}, {"albedo", 0.5}}}}},
      {"shapes",
       {{{"type", "quad"}, {"corner", {0, 0, -50}}, {"edge1", {1, 0, 0}}, {"edge2", {0, 1, 0}}, {"material", "w"}}}},
      {"environment", {{"radiance", {1, 1, 1}}}}};
  const Scene s = test::loadSceneJson(dir, scene);
  const RealLensCamera camera = *s.realLensCamera();
  const double halfDiagonal = std::hypot(18.0, 12.0);
  // Tabulate past the corner's field angle (found from the paraxial mapping, with margin).
  const double maxAngle = std::min(89.0, 1.3 * std::atan(halfDiagonal / camera.lens().paraxial().efl) * 180.0 / M_PI);
  const std::vector<IlluminationPoint> table = relativeIllumination(camera.lens(), maxAngle, 24, camera.filmZ(), 256);
  const test::Rendered r = test::renderScene(s);
  // Rings 3 mm wide from the centre to the corner: the rendered mean against the computed.
  const double cell = 36.0 / width;
  const int rings = 7;
  std::vector<double> rendered(rings, 0.0), computed(rings, 0.0);
  std::vector<int> count(rings, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double h = std::hypot((x + 0.5 - width / 2.0) * cell, (y + 0.5 - height / 2.0) * cell);
      const int ring = std::min(rings - 1, int(h / halfDiagonal * rings));
      const float* px = &r.image.rgb[3 * (size_t(y) * width + x)];
      rendered[ring] += (px[0] + px[1] + px[2]) / 3.0;
      computed[ring] += relativeIlluminationAt(table, h);
      ++count[ring];
    }
  for (int k = 0; k < rings; ++k) {
    ASSERT_GT(count[k], 0);
    const double a = rendered[k] / count[k], b = computed[k] / count[k];
    EXPECT_NEAR(a, b, 0.02 * b) << lensFile << " ring " << k << " (" << k * 3 << "-" << (k + 1) * 3 << " mm)";
  }
  // It does fall off: the outer ring is well below the centre.
  EXPECT_LT(rendered[rings - 1] / count[rings - 1], 0.9 * rendered[0] / count[0]) << lensFile;
}

TEST(RelativeIllumination, ARenderOfAUniformWhiteEnvironmentFallsOffAsComputed) {
  expectRenderFollowsRelativeIllumination("dgauss.50mm.dat", 2.04);
  expectRenderFollowsRelativeIllumination("wide.22mm.dat", 4.0);
}

}  // namespace
}  // namespace lensfarm
