// The thin-lens optics of 2013 report §4.1-§4.6: focusing, the pinhole limit, the image flip, refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "common/camera/thin_lens_camera.h"
#include "common/util/error.h"

namespace lensfarm {
namespace {

ThinLensParams seedParams() {
  ThinLensParams p;
  p.position = Vec3(0.3f, -0.2f, -2.9f);  // off the origin, and looking along a tilted axis
  p.lookAt = Vec3(0.1f, 0.05f, 0.0f);
  p.up = Vec3(0.0f, -1.0f, 0.0f);
  p.focalLength = 0.095;
  p.focusDistance = 2.9;
  p.sensorWidth = 0.1;
  p.fNumber = 2.0;  // a wide aperture makes focusing errors visible
  return p;
}

TEST(ThinLensCamera, ImageDistanceFollowsTheThinLensEquation) {
  const ThinLensCamera camera(seedParams(), 100, 100);
  EXPECT_NEAR(1.0 / 2.9 + 1.0 / camera.imageDistance(), 1.0 / 0.095, 1e-9);  // 2013 report eq. 6
  EXPECT_NEAR(camera.lensRadius(), 0.095 / 4.0, 1e-12);                      // 2013 report eq. 7: 2R = f/N
}

TEST(ThinLensCamera, RaysFromOneSensorPointMeetAtOnePointOfTheFocalPlane) {
  const ThinLensParams p = seedParams();
  const ThinLensCamera camera(p, 100, 100);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int cell = 0; cell < 20; ++cell) {
    const int i = int(u(rng) * 100), j = int(u(rng) * 100);
    const Vec2 uSensor(u(rng), u(rng));
    // Where the ray through the lens centre (the chief ray) meets the plane at S1.
    const CameraRay chief = camera.generateRay(i, j, uSensor, Vec2(0.5f));
    const auto onFocalPlane = [&](const CameraRay& r) {
      const double t = (p.focusDistance - glm::dot(r.origin - p.position, camera.forward())) /
                       glm::dot(r.direction, camera.forward());
      return DVec3(r.origin) + t * DVec3(r.direction);
    };
    const DVec3 target = onFocalPlane(chief);
    for (int k = 0; k < 200; ++k) {
      const CameraRay r = camera.generateRay(i, j, uSensor, Vec2(u(rng), u(rng)));
      const DVec3 q = onFocalPlane(r);
      EXPECT_LT(glm::length(q - target) / glm::length(target - DVec3(p.position)), 1e-5) << "cell " << i << "," << j;
    }
  }
}

TEST(ThinLensCamera, LensPointsCoverTheAperture) {
  const ThinLensCamera camera(seedParams(), 10, 10);
  double maxR = 0.0;
  for (int k = 0; k < 64; ++k) {
    const CameraRay r =
        camera.generateRay(5, 5, Vec2(0.5f), Vec2((float(k % 8) + 0.5f) / 8, (float(k / 8) + 0.5f) / 8));
    maxR = std::max(maxR, double(glm::length(r.origin - seedParams().position)));
  }
  EXPECT_LE(maxR, camera.lensRadius() * (1 + 1e-5));
  EXPECT_GT(maxR, 0.8 * camera.lensRadius());
}

TEST(ThinLensCamera, PinholeRaysAllLeaveTheLensCentre) {
  ThinLensParams p = seedParams();
  p.fNumber = std::numeric_limits<double>::infinity();
  const ThinLensCamera camera(p, 10, 10);
  EXPECT_TRUE(camera.isPinhole());
  for (float u : {0.0f, 0.3f, 0.99f}) {
    const CameraRay r = camera.generateRay(3, 7, Vec2(0.5f), Vec2(u, 1.0f - u));
    EXPECT_EQ(r.origin, p.position);
  }
}

TEST(ThinLensCamera, TheLensFlipsTheImage) {
  // Cell (0, 0) is the sensor's upper-left (sensor orientation). The lens inverts the image, so
  // it must see the scene's lower right: positive `right`, negative `up` components.
  const ThinLensCamera camera(seedParams(), 64, 48);
  const CameraRay upperLeftCell = camera.generateRay(0, 0, Vec2(0.5f), Vec2(0.5f));
  EXPECT_GT(glm::dot(upperLeftCell.direction, camera.right()), 0.0f);
  EXPECT_LT(glm::dot(upperLeftCell.direction, camera.up()), 0.0f);
  const CameraRay lowerRightCell = camera.generateRay(63, 47, Vec2(0.5f), Vec2(0.5f));
  EXPECT_LT(glm::dot(lowerRightCell.direction, camera.right()), 0.0f);
  EXPECT_GT(glm::dot(lowerRightCell.direction, camera.up()), 0.0f);
  // The chief ray of a cell makes the angle of view: tan(half angle) = (L/2) / S2.
  const CameraRay edge = camera.rayThrough(Vec2(-0.05f, 0.0f), Vec2(0.0f));
  const float tanHalf = glm::dot(edge.direction, camera.right()) / glm::dot(edge.direction, camera.forward());
  EXPECT_NEAR(tanHalf, 0.05 / camera.imageDistance(), 1e-6);
}

TEST(ThinLensCamera, PacketFormsGiveTheOneRayBits) {
  // generateRays / generatePinholeRays (vector loops over a packet's lanes) against
  // generateRay / generatePinholeRay, lane by lane, for random cells and samples.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 0x1.fffffep-1f);
  std::uniform_int_distribution<int> cell(0, 799);
  for (double fNumber : {16.0, std::numeric_limits<double>::infinity()}) {
    ThinLensParams p = seedParams();
    p.fNumber = fNumber;
    const ThinLensCamera camera(p, 800, 600);
    for (int round = 0; round < 200; ++round) {
      int i[kPacketWidth];
      float u0[kPacketWidth], u1[kPacketWidth], l0[kPacketWidth], l1[kPacketWidth];
      for (int k = 0; k < kPacketWidth; ++k)
        i[k] = cell(rng), u0[k] = u(rng), u1[k] = u(rng), l0[k] = u(rng), l1[k] = u(rng);
      const int j = round % 600;
      CameraRayLanes lens, pinhole;
      camera.generateRays(i, j, u0, u1, l0, l1, lens);
      camera.generatePinholeRays(i, j, u0, u1, pinhole);
      for (int k = 0; k < kPacketWidth; ++k) {
        const CameraRay a = camera.generateRay(i[k], j, Vec2(u0[k], u1[k]), Vec2(l0[k], l1[k]));
        const CameraRay b = camera.generatePinholeRay(i[k], j, Vec2(u0[k], u1[k]));
        const float la[6] = {lens.ox[k], lens.oy[k], lens.oz[k], lens.dx[k], lens.dy[k], lens.dz[k]};
        const float pa[6] = {pinhole.ox[k], pinhole.oy[k], pinhole.oz[k], pinhole.dx[k], pinhole.dy[k], pinhole.dz[k]};
        const float ea[6] = {a.origin.x, a.origin.y, a.origin.z, a.direction.x, a.direction.y, a.direction.z};
        const float eb[6] = {b.origin.x, b.origin.y, b.origin.z, b.direction.x, b.direction.y, b.direction.z};
        ASSERT_EQ(std::memcmp(la, ea, sizeof la), 0) << "lane " << k << " N = " << fNumber;
        ASSERT_EQ(std::memcmp(pa, eb, sizeof pa), 0) << "lane " << k << " N = " << fNumber;
      }
    }
  }
}

TEST(ThinLensCamera, RefusesImpossibleSetUps) {
  const auto fieldOf = [](ThinLensParams p) -> std::string {
    try {
      ThinLensCamera c(p, 10, 10);
    } catch (const InputError& e) {
      return e.where();
    }
    return "";
  };
  ThinLensParams p = seedParams();
  p.focusDistance = 0.095;  // S1 = f: the image would form at infinity
  EXPECT_EQ(fieldOf(p), "focus_distance");
  p.focusDistance = 0.05;
  EXPECT_EQ(fieldOf(p), "focus_distance");
  p.focusDistance = 0.095 * (1 + 1e-9);  // S2 finite in theory but unbounded in practice
  EXPECT_EQ(fieldOf(p), "focus_distance");
  p = seedParams();
  p.sensorWidth = 0.0;
  EXPECT_EQ(fieldOf(p), "sensor_width");
  p = seedParams();
  p.fNumber = 0.0;
  EXPECT_EQ(fieldOf(p), "f_number");
  p = seedParams();
  p.up = p.lookAt - p.position;  // parallel to the axis
  EXPECT_EQ(fieldOf(p), "up");
}

TEST(ThinLensCamera, EveryDegenerateFieldIsNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const float fnan = std::numeric_limits<float>::quiet_NaN(), finf = std::numeric_limits<float>::infinity();
  const auto fieldOf = [](const ThinLensParams& p) -> std::string {
    try {
      ThinLensCamera c(p, 10, 10);
    } catch (const InputError& e) {
      return e.where();
    }
    return "";
  };
  ASSERT_EQ(fieldOf(seedParams()), "");
  // Lengths: zero, negative and non-finite (0 is allowed for sensor_height: derived; inf for
  // f_number: a pinhole).
  struct Length {
    const char* field;
    double ThinLensParams::*member;
  };
  for (const Length& l :
       {Length{"focal_length", &ThinLensParams::focalLength}, Length{"sensor_width", &ThinLensParams::sensorWidth},
        Length{"sensor_height", &ThinLensParams::sensorHeight},
        Length{"focus_distance", &ThinLensParams::focusDistance}, Length{"f_number", &ThinLensParams::fNumber}})
    for (const double v : {0.0, -0.0, -1.0, nan, inf, -inf, 1e300}) {
      if ((std::string(l.field) == "sensor_height" && v == 0.0) ||
          (std::string(l.field) == "f_number" && (v == inf || v == 1e300)))
        continue;
      if (std::string(l.field) == "focus_distance" && v == inf) continue;  // focused at infinity: S2 = f
      // 1e300: beyond single precision for a sensor; a focus at infinity (fine); for f, the
      // scene loader names the unit mix-up (the camera alone sees S1 <= f).
      if (v == 1e300 && std::string(l.field) != "sensor_width" && std::string(l.field) != "sensor_height") continue;
      ThinLensParams p = seedParams();
      p.*l.member = v;
      EXPECT_EQ(fieldOf(p), l.field) << l.field << " = " << v;
    }
  // Vectors: non-finite components; look_at at the position; a zero up.
  struct Vector {
    const char* field;
    Vec3 ThinLensParams::*member;
  };
  for (const Vector& vec : {Vector{"position", &ThinLensParams::position}, Vector{"look_at", &ThinLensParams::lookAt},
                            Vector{"up", &ThinLensParams::up}})
    for (const float v : {fnan, finf, -finf}) {
      ThinLensParams p = seedParams();
      (p.*vec.member)[1] = v;
      EXPECT_EQ(fieldOf(p), vec.field) << vec.field << "[1] = " << v;
    }
  ThinLensParams p = seedParams();
  p.lookAt = p.position;
  p.focusDistance = 0.0;  // what a defaulted S1 would be: still the frame's fault
  EXPECT_EQ(fieldOf(p), "look_at");
  try {
    ThinLensCamera c(p, 10, 10);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("equals camera.position"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the view direction is undefined"), std::string::npos) << e.what();
  }
  p = seedParams();
  p.up = Vec3(0.0f);
  EXPECT_EQ(fieldOf(p), "up");
  // An f-number far below 0.5 (once: a lens radius beyond single precision), and a field of view
  // of 180 degrees (mixed units).
  p = seedParams();
  p.fNumber = 1e-300;
  EXPECT_EQ(fieldOf(p), "f_number");
  p = seedParams();
  p.sensorWidth = 1e5;  // 100 km of sensor 0.1 behind the lens
  EXPECT_EQ(fieldOf(p), "sensor_width");
  p = seedParams();
  p.sensorHeight = 1e5;
  EXPECT_EQ(fieldOf(p), "sensor_height");
}

TEST(ThinLensCamera, ExtremeLensValuesAreRefusedOnPrincipleOrGiveTraceableRays) {
  // N >= 0.5 is the physical limit for a lens in air (N = 1 / (2 NA), NA <= 1); below it the
  // aperture grows without bound (N = 1e-20 put ray origins beyond Embree's range: an abort).
  // An aperture beyond 1e18 (Embree asserts on origins beyond 1.8e18), a field of view under
  // 1e-6 degrees and a focal length with no finite reciprocal are refused too; what is accepted
  // gives finite rays that start within 1e18 of the camera, through every corner of the sensor
  // and every edge of the aperture.
  const auto errorOf = [](const ThinLensParams& p, int w = 10, int h = 10) -> std::pair<std::string, std::string> {
    try {
      ThinLensCamera c(p, w, h);
    } catch (const InputError& e) {
      return {e.where(), e.what()};
    }
    return {"", ""};
  };
  for (const double n : {0.4999, 1e-20, 1e-300, 5e-324, -0.5}) {
    ThinLensParams p = seedParams();
    p.fNumber = n;
    const auto [field, message] = errorOf(p);
    EXPECT_EQ(field, "f_number") << n;
    EXPECT_NE(message.find("0.5"), std::string::npos) << message;
    EXPECT_NE(message.find("NA <= 1"), std::string::npos) << message;
  }
  {
    ThinLensParams p = seedParams();  // f = 1e25 focused far away: R = 5e24
    p.focalLength = 1e25, p.sensorWidth = 1e24, p.focusDistance = 1e30, p.fNumber = 1.0;
    EXPECT_EQ(errorOf(p).first, "f_number");
    p.fNumber = 1e8;  // R = 5e16: fine
    EXPECT_EQ(errorOf(p).first, "");
  }
  {
    ThinLensParams p = seedParams();
    p.focalLength = 5e-324;  // 1 / f overflows
    EXPECT_EQ(errorOf(p).first, "focal_length");
  }
  for (const double lw : {1e-30, 5e-324, 1e-10}) {
    ThinLensParams p = seedParams();
    p.sensorWidth = lw;  // under 1e-6 degrees of view on f = 0.095
    const auto [field, message] = errorOf(p);
    EXPECT_EQ(field, "sensor_width") << lw;
    EXPECT_NE(message.find("below 1e-06"), std::string::npos) << message;
  }
  {
    ThinLensParams p = seedParams();
    p.sensorHeight = 1e-30;
    EXPECT_EQ(errorOf(p).first, "sensor_height");
  }
  // Accepted extremes: N = 0.5, N = 1e30 (R below float's normal range), S1 = 1e300, a
  // 0.0055 degree telephoto, a 179.99 degree wide angle, 16384 x 1 cells.
  std::vector<std::pair<ThinLensParams, std::pair<int, int>>> good;
  ThinLensParams p = seedParams();
  p.fNumber = 0.5;
  good.push_back({p, {10, 10}});
  p.fNumber = 1e30;
  good.push_back({p, {10, 10}});
  p = seedParams();
  p.focusDistance = 1e300;
  good.push_back({p, {10, 10}});
  p = seedParams();
  p.sensorWidth = 1e-5;
  good.push_back({p, {10, 10}});
  p = seedParams();
  p.focalLength = focalLengthFromAngleOfView(0.1, 179.99);
  good.push_back({p, {10, 10}});
  good.push_back({seedParams(), {16384, 1}});
  for (const auto& [params, size] : good) {
    ASSERT_EQ(errorOf(params, size.first, size.second).second, "");
    const ThinLensCamera camera(params, size.first, size.second);
    for (const int i : {0, size.first - 1})
      for (const int j : {0, size.second - 1})
        for (const float u : {0.0f, 0x1.fffffep-1f})
          for (const Vec2 lens : {Vec2(0.0f), Vec2(0.0f, 0.5f), Vec2(0x1.fffffep-1f), Vec2(0.5f, 0.0f)}) {
            const CameraRay ray = camera.generateRay(i, j, Vec2(u), lens);
            for (int k = 0; k < 3; ++k) {
              ASSERT_TRUE(std::isfinite(ray.direction[k]));
              ASSERT_LE(std::abs(ray.origin[k] - params.position[k]), kMaxRayOriginDistance);
            }
            ASSERT_NEAR(glm::length(ray.direction), 1.0f, 1e-5f);
          }
  }
}

}  // namespace
}  // namespace lensfarm

namespace lensfarm {
namespace {

// A bladed aperture (ThinLensParams::apertureBlades): the lens points are uniform over the
// regular n-gon inscribed in R, and a plane out of focus sees every sensor point's rays spread
// over that polygon's shape, scaled: the bokeh of a defocused point has the aperture's shape and
// area.
TEST(ThinLensCamera, ABladedApertureIsAUniformPolygonAndDefocusedPointsTakeItsShape) {
  for (const int blades : {3, 6, 9}) {
    ThinLensParams p;
    p.position = Vec3(0.0f);
    p.lookAt = Vec3(0.0f, 0.0f, 1.0f);
    p.focalLength = 0.05;
    p.focusDistance = 2.0;
    p.sensorWidth = 0.036;
    p.fNumber = 2.0;
    p.apertureBlades = blades;
    p.apertureRotation = 15.0;
    const ThinLensCamera camera(p, 64, 64);
    const double radius = camera.lensRadius(), step = 2.0 * M_PI / blades, rotation = 15.0 * M_PI / 180.0;
    // Inside the n-gon: for the point at angle t, its distance is within R cos(pi/n) / cos(t - centre of its edge).
    const auto edgeDistance = [&](double angle) {
      const double rel = std::fmod(angle - rotation + 4.0 * M_PI, step);
      return radius * std::cos(step / 2) / std::cos(rel - step / 2);
    };
    const int n = 200;
    int inOuterHalf = 0;
    double maxRatio = 0.0;
    // A plane at 4 m, out of focus: the rays from the sensor's centre spread over a scaled copy
    // of the aperture (the thin lens maps lens point r to r (1 - d / S1) around the axis).
    const double planeZ = 4.0, scale = 1.0 - planeZ / p.focusDistance;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Vec2 u((float(a) + 0.5f) / n, (float(b) + 0.5f) / n);
        const CameraRay ray = camera.generateRay(32, 32, Vec2(0.0f), u);
        // The lens point in the camera plane (position is the origin; x along right, y along up).
        const Vec2 lens(glm::dot(ray.origin, camera.right()), glm::dot(ray.origin, camera.up()));
        const double r = std::hypot(double(lens.x), double(lens.y)), t = std::atan2(double(lens.y), double(lens.x));
        maxRatio = std::max(maxRatio, r / edgeDistance(t));
        inOuterHalf += r > 0.5 * edgeDistance(t) ? 1 : 0;
        // On the out-of-focus plane: the same shape, scaled.
        const DVec3 hit = DVec3(ray.origin) + (planeZ - ray.origin.z) / ray.direction.z * DVec3(ray.direction);
        // The sensor centre's chief ray lies along the axis, so the spread is around it.
        const double hx = glm::dot(hit, DVec3(camera.right())), hy = glm::dot(hit, DVec3(camera.up()));
        const double hr = std::hypot(hx, hy), ht = std::atan2(hy, hx) + (scale < 0 ? M_PI : 0.0);
        EXPECT_LE(hr, std::abs(scale) * edgeDistance(ht) * (1.0 + 1e-4));
      }
    EXPECT_LE(maxRatio, 1.0 + 1e-5) << blades << " blades: every lens point inside the polygon";
    EXPECT_GT(maxRatio, 0.99) << "it reaches the edges";
    // Uniform in area: the share of points beyond half the edge distance is 3/4.
    EXPECT_NEAR(double(inOuterHalf) / (n * n), 0.75, 0.01) << blades;
  }
  ThinLensParams bad;
  bad.lookAt = Vec3(0.0f, 0.0f, 1.0f);
  bad.focalLength = 0.05;
  bad.focusDistance = 2.0;
  bad.sensorWidth = 0.036;
  bad.fNumber = 2.0;
  bad.apertureBlades = 2;
  EXPECT_THROW(ThinLensCamera(bad, 8, 8), InputError);
}

}  // namespace
}  // namespace lensfarm
