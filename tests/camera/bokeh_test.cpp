// Bokeh shows the aperture's shape: a small emitter far beyond the focus,
// against black, rendered through straight blades, curved blades and an aperture image; its
// image, binarised, is the aperture's shape scaled by the thin lens's blur, with its area, and the
// light it brings is the aperture's open share of the full square's (camera/aperture.h,
// "Exposure").
//
// The blur, from the thin-lens equation 1/S1 + 1/S2 = 1/f (camera/thin_lens_camera.h): a point
// on the axis at distance d images at S2' = f d / (d - f), so its rays through the lens point p
// meet the sensor (at S2) at p (S2 - S2') / S2' = -p S2 (d - S1) / (S1 d): the aperture scaled by
// m = S2 (d - S1) / (S1 d) and turned 180 degrees, which developing the sensor turns back
// (film/sensor.h). In the picture the bokeh is then the aperture as the header's convention draws
// it, at m R per unit, centred on the axis.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "common/camera/aperture.h"
#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The set-up: f = 50 mm at f/2 (R = 12.5 mm) focused at S1 = 1 m; the emitter, a square of side
// w at d = 5 m, covers a square of side w / |1 - d/S1| = w / 4 of the lens's plane seen from a
// sensor point (the thin lens maps lens point p to p (1 - d / S1) on that plane): a quarter of R,
// so the bokeh's edges are blurred by an eighth of its width and the interior pixels see it
// through 2 % of the aperture.
constexpr double kF = 0.05, kN = 2.0, kS1 = 1.0, kD = 5.0, kEmitter = 0.0125;
constexpr int kRes = 96;
constexpr double kBokehPixels = 64.0;  // the aperture's bounding diameter 2R in the picture
constexpr double kR = kF / (2.0 * kN);

double magnification() {
  const double s2 = kF * kS1 / (kS1 - kF);
  return s2 * (kD - kS1) / (kS1 * kD);
}

json bokehScene(uint64_t spp) {
  const double pitch = 2.0 * kR * magnification() / kBokehPixels;  // sensor cell
  const double w = kEmitter;
  return json{{"format", "lensfarm-scene/1"},
              {"camera",
               {{"type", "thin_lens"},
                {"position", {0, 0, 0}},
                {"look_at", {0, 0, 1}},
                {"up", {0, 1, 0}},
                {"focal_length", kF},
                {"sensor_width", pitch * kRes},
                {"focus_distance", kS1},
                {"f_number", kN}}},
              // A scene needs a surface: a black one behind the camera, which no camera ray meets.
              {"materials", {{"black", {{"type", "lambertian"}, {"albedo", 0.0}}}}},
              {"shapes",
               {{{"type", "quad"},
                 {"corner", {-1, -1, -10}},
                 {"edge1", {2, 0, 0}},
                 {"edge2", {0, 2, 0}},
                 {"material", "black"}}}},
              // Facing the camera: cross(edge1, edge2) = -z.
              {"lights",
               {{{"type", "quad"},
                 {"corner", {-w / 2, -w / 2, kD}},
                 {"edge1", {0, w, 0}},
                 {"edge2", {w, 0, 0}},
                 {"radiance", 1.0}}}},
              {"render", {{"resolution", {kRes, kRes}}, {"samples_per_pixel", spp}, {"max_bounces", 1}, {"seed", 3}}}};
}

// Picture pixel (column, row) -> the lens point (units R) whose rays the bokeh puts there.
Vec2 lensPointOf(int column, int row) {
  const double perPixel = 2.0 / kBokehPixels;
  return Vec2(float((column + 0.5 - kRes / 2.0) * perPixel), float((kRes / 2.0 - row - 0.5) * perPixel));
}

struct Bokeh {
  double iou = 0.0, areaRatio = 0.0, total = 0.0;
  double plateau = 0.0, interior = 0.0;  // expected and measured brightness well inside
  double expectedArea = 0.0;             // of the expected shape's pixels, units R^2
  // The checks every measured shape must pass: the expected pixels have the analytic area (so a
  // wrong scale cannot hide in both), the interior's brightness is the plateau, and the light
  // over the whole picture is the plateau times the open area (the emitter's footprint blurs
  // the shape's edges but keeps its integral).
  void expectConsistent(double openArea) const {
    EXPECT_NEAR(expectedArea, openArea, 0.03 * openArea);
    EXPECT_NEAR(interior, plateau, 0.05 * plateau) << "the interior's brightness";
    EXPECT_NEAR(total * std::pow(2.0 / kBokehPixels, 2) / plateau, openArea, 0.02 * openArea) << "the light it brings";
  }
};

// The render binarised at half the plateau L a / A (the share a of the aperture's area A through
// which an interior pixel sees the emitter), compared with the expected shape.
Bokeh measure(const test::Rendered& r, const std::function<bool(Vec2)>& inside, double openArea, double weight) {
  const double footprint = std::pow(kEmitter / std::abs(1.0 - kD / kS1) / kR, 2);  // units R^2
  Bokeh b;
  b.plateau = weight * footprint / openArea;
  int both = 0, either = 0, rendered = 0, expected = 0;
  double interior = 0.0;
  int interiorCount = 0;
  for (int row = 0; row < kRes; ++row)
    for (int col = 0; col < kRes; ++col) {
      const double v = r.image.at(col, row).g;
      b.total += v;
      const bool lit = v > 0.5 * b.plateau;
      const Vec2 p = lensPointOf(col, row);
      const bool shape = inside(p);
      both += lit && shape, either += lit || shape, rendered += lit, expected += shape;
      // Well inside: the emitter's footprint (half-width 1/8 R) lies within the shape.
      bool deep = shape;
      for (const float dx : {-0.2f, 0.2f})
        for (const float dy : {-0.2f, 0.2f}) deep = deep && inside(p + Vec2(dx, dy));
      if (deep) interior += v, ++interiorCount;
    }
  b.iou = double(both) / either;
  b.areaRatio = double(rendered) / expected;
  b.expectedArea = expected * std::pow(2.0 / kBokehPixels, 2);
  b.interior = interiorCount ? interior / interiorCount : 0.0;
  return b;
}

// An asymmetric, non-convex letter: "F" (stem on the left, arms to the right at the top and the
// middle), in units R over [-1, 1]^2, as the photographer reads it.
bool letterF(Vec2 p) {
  const auto in = [&](double x0, double x1, double y0, double y1) {
    return p.x >= x0 && p.x < x1 && p.y >= y0 && p.y < y1;
  };
  return in(-0.7, -0.25, -0.9, 0.9) || in(-0.25, 0.8, 0.5, 0.9) || in(-0.25, 0.45, -0.15, 0.25);
}

void writeMaskPng(const std::filesystem::path& path, int side, const std::function<float(Vec2)>& t) {
  Image image;
  image.width = image.height = side;
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      const float v = t(Vec2(float(-1.0 + 2.0 * (x + 0.5) / side), float(1.0 - 2.0 * (y + 0.5) / side)));
      image.rgb.insert(image.rgb.end(), {v, v, v});
    }
  // Clamp tone map: the automatic exposure scales the mean to 1, so 1 stays 255 and 0 stays 0.
  writePng(path, image, ExposureSettings{0.0, ToneMap::kClamp});
}

constexpr uint64_t kSpp = 1024;

TEST(Bokeh, StraightBladesGiveAHexagonOfTheirArea) {
  test::TempDir dir;
  json scene = bokehScene(kSpp);
  scene["camera"]["aperture_blades"] = 6;
  scene["camera"]["aperture_rotation"] = 90;  // a vertex at the top
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  const auto hexagon = [](Vec2 p) {
    const double phi = std::atan2(double(p.y), double(p.x)) - M_PI / 2.0;
    const double rel = std::fmod(phi + 4.0 * M_PI, M_PI / 3.0) - M_PI / 6.0;
    return std::hypot(double(p.x), double(p.y)) <= std::cos(M_PI / 6.0) / std::cos(rel);
  };
  const Bokeh b = measure(r, hexagon, 3.0 * std::sin(M_PI / 3.0), 1.0);
  b.expectConsistent(3.0 * std::sin(M_PI / 3.0));
  EXPECT_GT(b.iou, 0.9);
  EXPECT_NEAR(b.areaRatio, 1.0, 0.04);
}

TEST(Bokeh, CurvedBladesGiveTheRoundedPolygonOfTheirArea) {
  test::TempDir dir;
  json scene = bokehScene(kSpp);
  scene["camera"]["aperture_blades"] = 5;
  scene["camera"]["aperture_curvature"] = 0.6;
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  // The boundary from the arc's circle (as in aperture_test.cpp): centre dc along the bisector.
  const double c = 0.6, rho = 1.0 / c, step = 2.0 * M_PI / 5,
               dc = std::cos(M_PI / 5) - std::sqrt(rho * rho - std::pow(std::sin(M_PI / 5), 2));
  const auto shape = [&](Vec2 p) {
    const double phi = std::atan2(double(p.y), double(p.x));
    double rel = std::fmod(phi + 4.0 * M_PI, step);
    const double uc = dc * std::cos(rel - step / 2);
    return std::hypot(double(p.x), double(p.y)) <= uc + std::sqrt(uc * uc - dc * dc + rho * rho);
  };
  const double beta = std::asin(c * std::sin(M_PI / 5));
  const double area = 2.5 * std::sin(step) + 5 * rho * rho * (beta - std::sin(beta) * std::cos(beta));
  const Bokeh b = measure(r, shape, area, 1.0);
  b.expectConsistent(area);
  EXPECT_GT(b.iou, 0.9);
  EXPECT_NEAR(b.areaRatio, 1.0, 0.04);
  // And it is not the straight pentagon: the arcs reach beyond its edges.
  const auto pentagon = [&](Vec2 p) {
    const double rel = std::fmod(std::atan2(double(p.y), double(p.x)) + 4.0 * M_PI, step) - step / 2;
    return std::hypot(double(p.x), double(p.y)) <= std::cos(M_PI / 5) / std::cos(rel);
  };
  const double pentagonArea = 2.5 * std::sin(step);
  EXPECT_GT(area / pentagonArea, 1.08);
  EXPECT_GT(measure(r, pentagon, pentagonArea, pentagonArea / area).areaRatio, 1.04);
}

// An aperture image: a letter F written as a PNG with the project's writer. Its bokeh is the F,
// upright and unmirrored; and the light it lets through, against the fully open square's and a
// half-black image's, is in the ratio of their open areas.
TEST(Bokeh, AnApertureImageGivesItsShapeAndItsShareOfTheLight) {
  test::TempDir dir;
  const int side = 64;
  writeMaskPng(dir.path() / "f.png", side, [](Vec2 p) { return letterF(p) ? 1.0f : 0.0f; });
  writeMaskPng(dir.path() / "open.png", side, [](Vec2) { return 1.0f; });
  writeMaskPng(dir.path() / "half.png", side, [](Vec2 p) { return p.x < 0.0f ? 1.0f : 0.0f; });
  const auto render = [&](const std::string& file) {
    json scene = bokehScene(kSpp);
    scene["camera"]["aperture_image"] = file;
    return test::renderScene(test::loadSceneJson(dir, scene));
  };
  // The open areas from the masks as written (units R^2): the pixels' centres decide.
  const auto areaOf = [&](const std::function<bool(Vec2)>& in) {
    int count = 0;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x)
        count += in(Vec2(float(-1.0 + 2.0 * (x + 0.5) / side), float(1.0 - 2.0 * (y + 0.5) / side)));
    return 4.0 * count / (side * side);
  };
  const double areaF = areaOf(letterF), areaOpen = 4.0, areaHalf = 2.0;
  const test::Rendered f = render("f.png"), open = render("open.png"), half = render("half.png");
  // The weight is the mean transmission T = A / 4 (an image over the square of side 2R).
  const Bokeh bf = measure(f, letterF, areaF, areaF / 4.0);
  bf.expectConsistent(areaF);
  EXPECT_GT(bf.iou, 0.9);
  EXPECT_NEAR(bf.areaRatio, 1.0, 0.04);
  // Mirrored or turned, the F would not match.
  const Bokeh mirrored = measure(
      f, [](Vec2 p) { return letterF(Vec2(-p.x, p.y)); }, areaF, areaF / 4.0);
  EXPECT_LT(mirrored.iou, 0.6);
  const Bokeh bo = measure(
      open, [](Vec2 p) { return std::abs(p.x) <= 1.0f && std::abs(p.y) <= 1.0f; }, areaOpen, areaOpen / 4.0);
  const Bokeh bh = measure(
      half, [](Vec2 p) { return p.x < 0.0f && std::abs(p.x) <= 1.0f && std::abs(p.y) <= 1.0f; }, areaHalf, 0.5);
  bo.expectConsistent(areaOpen);
  bh.expectConsistent(areaHalf);
  EXPECT_GT(bo.iou, 0.9);
  EXPECT_GT(bh.iou, 0.9);
  // Energy: every sample that meets the emitter brings L T / spp, so a render's total over its
  // pixels is (hits) L T / spp and its relative noise about 1 / sqrt(hits).
  const auto relativeNoise = [&](const Bokeh& b, double t) { return 1.0 / std::sqrt(b.total * kSpp / t); };
  const double noiseF = std::hypot(relativeNoise(bf, areaF / 4.0), relativeNoise(bo, areaOpen / 4.0));
  EXPECT_NEAR(bf.total / bo.total, areaF / areaOpen, 4.0 * noiseF * areaF / areaOpen);
  const double noiseHalf = std::hypot(relativeNoise(bh, 0.5), relativeNoise(bo, areaOpen / 4.0));
  EXPECT_NEAR(bh.total / bo.total, areaHalf / areaOpen, 4.0 * noiseHalf * areaHalf / areaOpen);
}

// The bladed iris keeps the 2013 report's exposure (camera/aperture.h): straight or curved blades let
// through the same light as the round aperture at the same N; only the shape of the blur changes.
TEST(Bokeh, AnIrisOfAnyShapeKeepsTheSeedsExposure) {
  test::TempDir dir;
  json round = bokehScene(128);
  json bladed = round, curvedBlades = round;
  bladed["camera"]["aperture_blades"] = 5;
  curvedBlades["camera"]["aperture_blades"] = 5;
  curvedBlades["camera"]["aperture_curvature"] = 0.5;
  const double total = test::renderScene(test::loadSceneJson(dir, round)).mean[1];
  for (const json& s : {bladed, curvedBlades}) {
    const double other = test::renderScene(test::loadSceneJson(dir, s)).mean[1];
    EXPECT_NEAR(other / total, 1.0, 0.03);
  }
}

}  // namespace
}  // namespace lensfarm
