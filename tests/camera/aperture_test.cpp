// The thin lens's aperture (camera/aperture.h): its samplers against geometry derived here
// independently (the curved blades' boundary as a ray meeting the arc's circle, their area as the
// polygon plus circular segments), the original straight-blade sampler's bits, the image sampler's histogram,
// the rasterised transmission, and the scene fields that ask for it.
#include "common/camera/aperture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <vector>

#include "common/film/image_io.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/support/chi2.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// The curved n-gon's boundary along direction phi (unit circumradius), derived afresh: the edge
// the direction crosses is an arc of radius rho = 1 / c through two adjacent vertices
// (cos(b +- pi/n), sin(b +- pi/n)), b its bisector's angle, so its centre is C = dc (cos b, sin b)
// with dc = cos(pi/n) - sqrt(rho^2 - sin^2(pi/n)) (the vertex at distance rho from C, on the
// origin's side of the chord's far end). The ray t (cos phi, sin phi) meets |t u - C| = rho at
// t = u.C + sqrt((u.C)^2 - |C|^2 + rho^2).
double curvedBoundary(double phi, int n, double c, double rotation) {
  const double step = 2.0 * M_PI / n;
  double rel = std::fmod(phi - rotation, step);
  if (rel < 0.0) rel += step;
  const double b = phi - rel + step / 2.0;
  const double rho = 1.0 / c, dc = std::cos(M_PI / n) - std::sqrt(rho * rho - std::pow(std::sin(M_PI / n), 2));
  const double uc = dc * std::cos(phi - b);
  return uc + std::sqrt(uc * uc - dc * dc + rho * rho);
}

// Its area: the inscribed polygon plus n circular segments of the arc's circle, each cut by a
// chord of half-length sin(pi/n): half-angle beta with rho sin beta = sin(pi/n), area
// rho^2 (beta - sin beta cos beta).
double curvedArea(int n, double c) {
  const double rho = 1.0 / c, beta = std::asin(c * std::sin(M_PI / n));
  return 0.5 * n * std::sin(2.0 * M_PI / n) + n * rho * rho * (beta - std::sin(beta) * std::cos(beta));
}

// The integral of f over [a, b] by composite Simpson with m (even) intervals.
template <typename F>
double simpson(F f, double a, double b, int m) {
  const double h = (b - a) / m;
  double s = f(a) + f(b);
  for (int k = 1; k < m; ++k) s += f(a + k * h) * (k % 2 ? 4.0 : 2.0);
  return s * h / 3.0;
}

Aperture curved(int blades, double curvature, double rotation = 10.0) {
  return Aperture(ApertureSpec{blades, rotation, curvature, nullptr});
}

// Uniform by area over the exact curved polygon: every point inside, the boundary reached, and a
// chi-squared test over (angle, (r / r(phi))^2) cells, whose expected shares are the wedge areas
// (1/2) integral r(phi)^2 dphi of the independent boundary over the independent total area
// (uniform by area <=> phi has density r(phi)^2 / (2 A) and (r / r(phi))^2 is uniform given phi).
TEST(Aperture, CurvedBladesAreUniformInAreaOverTheirExactShape) {
  const struct {
    int blades;
    double curvature;
  } cases[] = {{5, 0.5}, {6, 0.25}, {9, 0.8}, {3, 0.97}, {7, 0.02}};
  const int angleBins = 48, radialBins = 8;
  const uint64_t count = 300000;
  for (const auto& c : cases) {
    const double rotation = 10.0 * M_PI / 180.0;
    const Aperture aperture = curved(c.blades, c.curvature);
    ASSERT_EQ(aperture.kind(), Aperture::Kind::kCurvedPolygon);
    const double area = curvedArea(c.blades, c.curvature);
    EXPECT_NEAR(aperture.openArea(), area, 1e-12 * area) << c.blades << " blades, curvature " << c.curvature;
    const auto r2half = [&](double phi) {
      return 0.5 * std::pow(curvedBoundary(phi, c.blades, c.curvature, rotation), 2);
    };
    EXPECT_NEAR(simpson(r2half, 0.0, 2.0 * M_PI, 1 << 16), area, 1e-6) << "the two derivations of the area agree";

    std::vector<double> observed(size_t(angleBins * radialBins), 0.0);
    test::Pcg32 rng(uint64_t(c.blades) * 1000 + 7);
    double maxRatio = 0.0;
    for (uint64_t k = 0; k < count; ++k) {
      const Vec2 p = aperture.sample(Vec2(rng.uniform(), rng.uniform()));
      double phi = std::atan2(double(p.y), double(p.x));
      if (phi < 0.0) phi += 2.0 * M_PI;
      const double ratio = std::hypot(double(p.x), double(p.y)) / curvedBoundary(phi, c.blades, c.curvature, rotation);
      maxRatio = std::max(maxRatio, ratio);
      const int a = std::min(int(phi / (2.0 * M_PI) * angleBins), angleBins - 1);
      const int r = std::min(int(ratio * ratio * radialBins), radialBins - 1);
      observed[size_t(a * radialBins + r)] += 1.0;
    }
    EXPECT_LE(maxRatio, 1.0 + 1e-6) << c.blades << " blades, curvature " << c.curvature << ": inside the shape";
    EXPECT_GT(maxRatio, 0.995) << "the boundary is reached";
    double chi2 = 0.0;
    for (int a = 0; a < angleBins; ++a) {
      const double share = simpson(r2half, 2.0 * M_PI * a / angleBins, 2.0 * M_PI * (a + 1) / angleBins, 512) / area;
      for (int r = 0; r < radialBins; ++r) {
        const double expected = double(count) * share / radialBins;
        chi2 += std::pow(observed[size_t(a * radialBins + r)] - expected, 2) / expected;
      }
    }
    const double p = test::chi2PValue(chi2, angleBins * radialBins - 1);
    EXPECT_TRUE(test::passes(p, 0.01, int(std::size(cases))))
        << c.blades << " blades, curvature " << c.curvature << ": chi2 " << chi2 << ", p " << p;
  }
}

// Curvature 1 is the circle: every point in the unit disk, the disk's moments (E[x] = E[y] = 0,
// E[x^2] = E[y^2] = 1/4, E[r^2] = 1/2) within 4 standard errors, and its area pi.
TEST(Aperture, CurvatureOneIsTheCircle) {
  for (const int blades : {3, 6, 11}) {
    const Aperture aperture = curved(blades, 1.0);
    EXPECT_NEAR(aperture.openArea(), M_PI, 1e-12);
    const int n = 400;  // a stratified grid of lens samples
    double sx = 0, sy = 0, sxx = 0, syy = 0, maxR = 0;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Vec2 p = aperture.sample(Vec2((float(a) + 0.5f) / float(n), (float(b) + 0.5f) / float(n)));
        sx += p.x, sy += p.y, sxx += double(p.x) * p.x, syy += double(p.y) * p.y;
        maxR = std::max(maxR, std::hypot(double(p.x), double(p.y)));
      }
    const double m = double(n) * n;
    EXPECT_LE(maxR, 1.0 + 1e-6);
    EXPECT_GT(maxR, 0.995);
    // Standard errors of a uniform disk's: sd(x) = 1/2, sd(x^2) = sqrt(1/8 - 1/16) = 1/4.
    const double se1 = 0.5 / std::sqrt(m), se2 = 0.25 / std::sqrt(m);
    EXPECT_NEAR(sx / m, 0.0, 4 * se1) << blades;
    EXPECT_NEAR(sy / m, 0.0, 4 * se1) << blades;
    EXPECT_NEAR(sxx / m, 0.25, 4 * se2) << blades;
    EXPECT_NEAR(syy / m, 0.25, 4 * se2) << blades;
  }
  // A tiny curvature is the straight polygon: its area, and no point beyond its edges.
  const Aperture nearlyStraight = curved(6, 1e-9);
  EXPECT_NEAR(nearlyStraight.openArea(), 3.0 * std::sin(M_PI / 3.0), 1e-8);
  for (int a = 0; a < 100; ++a) {
    const Vec2 p = nearlyStraight.sample(Vec2((float(a) + 0.5f) / 100.0f, 0.999f));
    double phi = std::atan2(double(p.y), double(p.x)) - 10.0 * M_PI / 180.0;
    const double rel = std::fmod(phi + 4.0 * M_PI, M_PI / 3.0) - M_PI / 6.0;
    EXPECT_LE(std::hypot(double(p.x), double(p.y)), std::cos(M_PI / 6.0) / std::cos(rel) * (1.0 + 1e-6));
  }
}

// The straight blades' sampler gives the original bits: lens points the original sampleAperture
// (thin_lens_camera.h before the aperture had a file of its own) gave for rotation 15 degrees,
// recorded as exact hexadecimal floats.
TEST(Aperture, StraightBladesKeepTheSeedsBits) {
  const struct {
    int blades;
    float ux, uy, x, y;
  } seed[] = {{3, 0x1.99999ap-4, 0x1.99999ap-3, 0x1.621634p-2, 0x1.86e61p-3},
              {3, 0x1.7ae148p-2, 0x1.d1eb86p-1, -0x1.96698ep-4, -0x1.14e98p-2},
              {3, 0x1p-1, 0x1p-1, -0x1.5db3d4p-2, -0x1.76cf5cp-4},
              {3, 0x1.75c29p-1, 0x1.99999ap-5, -0x1.60c37p-4, -0x1.93cf16p-2},
              {3, 0x1.fae148p-1, 0x1.51eb86p-1, 0x1.151918p-1, -0x1.3ddfe8p-3},
              {3, 0x1.001a36p-2, 0x1.ff7ceep-1, -0x1.38dafcp-1, 0x1.396606p-1},
              {6, 0x1.99999ap-4, 0x1.99999ap-3, 0x1.46fe3ep-1, 0x1.3d772cp-2},
              {6, 0x1.7ae148p-2, 0x1.d1eb86p-1, -0x1.c4beaep-2, -0x1.4a39cep-4},
              {6, 0x1p-1, 0x1p-1, -0x0p+0, -0x0p+0},
              {6, 0x1.75c29p-1, 0x1.99999ap-5, -0x1.09c77ap-3, -0x1.2cc778p-1},
              {6, 0x1.fae148p-1, 0x1.51eb86p-1, 0x1.b3ce22p-1, -0x1.14614cp-4},
              {6, 0x1.001a36p-2, 0x1.ff7ceep-1, -0x1.ff9b7p-2, 0x1.003f4cp-1},
              {9, 0x1.99999ap-4, 0x1.99999ap-3, 0x1.af0f7p-1, 0x1.684c2ap-2},
              {9, 0x1.7ae148p-2, 0x1.d1eb86p-1, -0x1.1d5996p-1, 0x1.505c32p-4},
              {9, 0x1p-1, 0x1p-1, -0x1.489ce4p-1, -0x1.6034dep-3},
              {9, 0x1.75c29p-1, 0x1.99999ap-5, -0x1.5b8152p-3, -0x1.743a5ap-1},
              {9, 0x1.fae148p-1, 0x1.51eb86p-1, 0x1.cddfcep-1, 0x1.a808f8p-6},
              {9, 0x1.001a36p-2, 0x1.ff7ceep-1, -0x1.6a5f26p-2, 0x1.6ad67cp-2},
              {64, 0x1.99999ap-4, 0x1.99999ap-3, 0x1.a10efcp-2, 0x1.eed1c8p-2},
              {64, 0x1.7ae148p-2, 0x1.d1eb86p-1, -0x1.6b9ed6p-1, 0x1.ac7952p-2},
              {64, 0x1p-1, 0x1p-1, -0x0p+0, -0x0p+0},
              {64, 0x1.75c29p-1, 0x1.99999ap-5, 0x1.e8833cp-5, -0x1.b145cep-1},
              {64, 0x1.fae148p-1, 0x1.51eb86p-1, 0x1.2ae572p-1, 0x1.15f602p-3},
              {64, 0x1.001a36p-2, 0x1.ff7ceep-1, -0x1.cd8c58p-6, 0x1.32aac8p-4}};
  for (const auto& s : seed) {
    const Aperture aperture(ApertureSpec{s.blades, 15.0, 0.0, nullptr});
    EXPECT_EQ(aperture.kind(), Aperture::Kind::kPolygon);
    EXPECT_EQ(aperture.weight(), 1.0f);
    const Vec2 now = aperture.sample(Vec2(s.ux, s.uy));
    EXPECT_EQ(now.x, s.x) << s.blades << " blades at (" << s.ux << ", " << s.uy << ")";
    EXPECT_EQ(now.y, s.y) << s.blades << " blades at (" << s.ux << ", " << s.uy << ")";
  }
}

// An image: pixels drawn in proportion to their transmission (chi-squared over the pixels, none of
// the black ones ever drawn), each point inside its pixel, oriented as the header says (row 0 at
// y = +1, column 0 at x = -1), and every sample weighing the mean transmission.
TEST(Aperture, AnImageIsSampledInProportionToItsTransmission) {
  const int side = 8;
  std::vector<float> t(side * side);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x)
      t[size_t(y * side + x)] = (x + 2 * y) % 5 == 0 ? 0.0f : float((x * 7 + y * 3) % 11) / 10.0f;
  double sum = 0.0;
  for (const float v : t) sum += v;
  const Aperture aperture(ApertureSpec{0, 0.0, 0.0, ApertureImage::fromTransmission(t, side, "test image")});
  EXPECT_EQ(aperture.kind(), Aperture::Kind::kImage);
  EXPECT_FLOAT_EQ(aperture.weight(), float(sum / (side * side)));
  EXPECT_NEAR(aperture.openArea(), 4.0 * sum / (side * side), 1e-12);
  std::vector<double> observed(t.size(), 0.0);
  test::Pcg32 rng(1);
  const uint64_t count = 200000;
  for (uint64_t k = 0; k < count; ++k) {
    const Vec2 p = aperture.sample(Vec2(rng.uniform(), rng.uniform()));
    ASSERT_LE(std::abs(p.x), 1.0f);
    ASSERT_LE(std::abs(p.y), 1.0f);
    // Independently of the code's lookup: column from x = -1, row from y = +1.
    const int x = std::min(int((p.x + 1.0) / 2.0 * side), side - 1),
              y = std::min(int((1.0 - p.y) / 2.0 * side), side - 1);
    observed[size_t(y * side + x)] += 1.0;
    ASSERT_GT(aperture.transmission(p), 0.0f);
  }
  double chi2 = 0.0;
  int cells = 0;
  for (size_t k = 0; k < t.size(); ++k) {
    if (t[k] == 0.0f) {
      EXPECT_EQ(observed[k], 0.0) << "a black pixel is never drawn";
      continue;
    }
    const double expected = double(count) * t[k] / sum;
    chi2 += std::pow(observed[k] - expected, 2) / expected;
    ++cells;
  }
  const double p = test::chi2PValue(chi2, cells - 1);
  EXPECT_TRUE(test::passes(p, 0.01, 1)) << "chi2 " << chi2 << ", p " << p;
  // Orientation: the top-left pixel is at x < 0, y > 0.
  std::vector<float> corner(4, 0.0f);
  corner[0] = 1.0f;
  const Aperture topLeft(ApertureSpec{0, 0.0, 0.0, ApertureImage::fromTransmission(corner, 2, "corner")});
  const Vec2 q = topLeft.sample(Vec2(0.3f, 0.8f));
  EXPECT_LT(q.x, 0.0f);
  EXPECT_GT(q.y, 0.0f);
  EXPECT_FLOAT_EQ(topLeft.weight(), 0.25f);
}

// The transmission on an n x n grid (for the diffraction's pupil function): its sum times the
// cell's area is the open area; an image's grid at its own size is the image, at half its size
// the means of 2 x 2 pixels.
TEST(Aperture, RasterizedTransmissionHasTheOpenArea) {
  const int n = 256;
  const double cell = (2.0 / n) * (2.0 / n);
  for (const Aperture& a : {Aperture(), Aperture(ApertureSpec{6, 0.0, 0.0, nullptr}), curved(5, 0.4)}) {
    std::vector<float> grid;
    a.rasterize(n, grid);
    ASSERT_EQ(grid.size(), size_t(n) * n);
    double sum = 0.0;
    for (const float v : grid) sum += v;
    EXPECT_NEAR(sum * cell, a.openArea(), 2e-3 * a.openArea());
  }
  // Orientation: a hexagon with a vertex at the top (rotation 90) reaches the top row's centre
  // cells but not the left edge's middle.
  std::vector<float> hex;
  Aperture(ApertureSpec{6, 90.0, 0.0, nullptr}).rasterize(16, hex);
  EXPECT_GT(hex[7], 0.0f);
  EXPECT_EQ(hex[8 * 16], 0.0f);
  std::vector<float> t(16);
  for (int k = 0; k < 16; ++k) t[size_t(k)] = float(k) / 15.0f;
  const Aperture image(ApertureSpec{0, 0.0, 0.0, ApertureImage::fromTransmission(t, 4, "ramp")});
  std::vector<float> same, half;
  image.rasterize(4, same);
  image.rasterize(2, half);
  for (int k = 0; k < 16; ++k) EXPECT_FLOAT_EQ(same[size_t(k)], t[size_t(k)]);
  EXPECT_FLOAT_EQ(half[0], (t[0] + t[1] + t[4] + t[5]) / 4);
  EXPECT_FLOAT_EQ(half[3], (t[10] + t[11] + t[14] + t[15]) / 4);
}

// The scene's fields: read, and each bad one refused naming it (and the file, for an image).
json thinLensScene() {
  json scene = test::minimalSceneJson();
  scene["camera"]["type"] = "thin_lens";
  scene["camera"]["f_number"] = 2.8;
  return scene;
}

void expectRefused(const test::TempDir& dir, const json& scene, const std::string& field,
                   const std::string& also = "") {
  try {
    test::loadSceneJson(dir, scene);
    ADD_FAILURE() << "accepted; expected an error naming " << field;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    if (!also.empty()) {
      EXPECT_NE(std::string(e.what()).find(also), std::string::npos) << e.what();
    }
  }
}

void writeMask(const std::filesystem::path& path, int width, int height, float value) {
  Image image;
  image.width = width, image.height = height;
  image.rgb.assign(size_t(3 * width * height), value);
  if (value > 0.0f) image.rgb[0] = image.rgb[1] = image.rgb[2] = 0.0f;  // not uniform: exposure keeps 1 at 255
  writePng(path, image, ExposureSettings{0.0, ToneMap::kClamp});
}

TEST(ApertureFields, CurvatureAndImageAreReadAndChecked) {
  test::TempDir dir;
  json scene = thinLensScene();
  scene["camera"]["aperture_blades"] = 7;
  scene["camera"]["aperture_curvature"] = 0.5;
  EXPECT_DOUBLE_EQ(test::loadSceneJson(dir, scene).camera().aperture().spec().curvature, 0.5);
  scene["camera"]["aperture_curvature"] = 1.5;
  expectRefused(dir, scene, "camera.aperture_curvature");
  scene["camera"]["aperture_curvature"] = -0.1;
  expectRefused(dir, scene, "camera.aperture_curvature");
  scene["camera"].erase("aperture_blades");
  scene["camera"]["aperture_curvature"] = 0.5;
  expectRefused(dir, scene, "camera.aperture_curvature", "aperture_blades");

  json img = thinLensScene();
  writeMask(dir.path() / "mask.png", 8, 8, 1.0f);
  img["camera"]["aperture_image"] = "mask.png";
  const Scene s = test::loadSceneJson(dir, img);
  EXPECT_EQ(s.camera().aperture().kind(), Aperture::Kind::kImage);
  EXPECT_FLOAT_EQ(s.camera().aperture().weight(), 63.0f / 64.0f) << "one black pixel of 64";
  EXPECT_EQ(s.assets.count("mask.png"), 1u) << "shipped to workers like a mesh";

  json both = img;
  both["camera"]["aperture_blades"] = 6;
  expectRefused(dir, both, "camera.aperture_image", "aperture_blades");
  json missing = img;
  missing["camera"]["aperture_image"] = "nowhere.png";
  expectRefused(dir, missing, "camera.aperture_image", "nowhere.png");
  writeMask(dir.path() / "wide.png", 8, 4, 1.0f);
  json wide = img;
  wide["camera"]["aperture_image"] = "wide.png";
  expectRefused(dir, wide, "camera.aperture_image", "square");
  writeMask(dir.path() / "black.png", 8, 8, 0.0f);
  json black = img;
  black["camera"]["aperture_image"] = "black.png";
  expectRefused(dir, black, "camera.aperture_image", "black");
  {
    std::ofstream out(dir.path() / "junk.png", std::ios::binary);
    out << "this is not an image";
  }
  json junk = img;
  junk["camera"]["aperture_image"] = "junk.png";
  expectRefused(dir, junk, "camera.aperture_image", "junk.png");
  json pinhole = img;
  pinhole["camera"]["f_number"] = "infinity";
  expectRefused(dir, pinhole, "camera.aperture_image", "f_number");
}

}  // namespace
}  // namespace lensfarm
