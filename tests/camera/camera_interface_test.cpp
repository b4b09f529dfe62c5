// The camera interface (camera/camera.h): every camera's packet of rays is its one-ray rays bit
// for bit; the thin lens's connection (what the light tracer asks) inverts its rays and carries the
// importance w_ap S2^2 / (A_cell cos^3 theta) computed here independently; hard points (on the
// lens, behind it, beside it, off the sensor, 1e6 away) give no connection or a finite one; and the registry
// (scene/scene_camera.h) picks the model a scene declares and a pinhole where blur is invisible.
#include "common/camera/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/camera/pinhole_camera.h"
#include "common/camera/real_lens_camera.h"
#include "common/camera/thin_lens_camera.h"
#include "common/math/sampling.h"
#include "common/render/render_scene.h"
#include "common/scene/scene_camera.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

ThinLensParams lensParams(double fNumber, int blades = 0) {
  ThinLensParams p;
  p.position = Vec3(0.3f, -0.2f, 1.0f);
  p.lookAt = Vec3(0.5f, 0.1f, 5.0f);
  p.up = Vec3(0.1f, 1.0f, 0.0f);
  p.focalLength = 0.05;
  p.focusDistance = 3.0;
  p.sensorWidth = 0.036;
  p.fNumber = fNumber;
  p.apertureBlades = blades;
  p.apertureRotation = 17.0;
  return p;
}

// A packet of lanes in row 7 with scattered cells and samples (lanes past `count` left unset).
CameraSampleLanes lanesOf(int count, int width) {
  CameraSampleLanes s;
  s.count = count;
  s.row = 7;
  for (int k = 0; k < kPacketWidth; ++k) {
    s.column[k] = (k * 13 + 5) % width;
    s.u0[k] = float(k) / kPacketWidth, s.u1[k] = 1.0f - float(k + 1) / (kPacketWidth + 1);
    s.lens0[k] = float((k * 7) % kPacketWidth) / kPacketWidth, s.lens1[k] = float(k) / (kPacketWidth + 3);
    s.wavelengthNm[k] = 420.0 + 20.0 * k;
  }
  return s;
}

void expectSameBits(const CameraRay& a, const CameraRay& b, int lane) {
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(a.origin[c], b.origin[c]) << "lane " << lane << " origin " << c;
    EXPECT_EQ(a.direction[c], b.direction[c]) << "lane " << lane << " direction " << c;
  }
}

TEST(CameraInterface, ThinLensAndPinholePacketsAreTheirOneRayRaysBitForBit) {
  for (const int blades : {0, 6}) {
    const ThinLensCamera thin(lensParams(2.0, blades), 64, 48);
    const PinholeCamera pinhole(thin);
    const CameraSampleLanes s = lanesOf(kPacketWidth, 64);
    CameraRayLanes rays, pinholeRays;
    float weight[kPacketWidth], pinholeWeight[kPacketWidth];
    thin.sampleRays(s, rays, weight);
    pinhole.sampleRays(s, pinholeRays, pinholeWeight);
    for (int k = 0; k < kPacketWidth; ++k) {
      expectSameBits(rays.ray(k),
                     thin.generateRay(s.column[k], 7, Vec2(s.u0[k], s.u1[k]), Vec2(s.lens0[k], s.lens1[k])), k);
      expectSameBits(pinholeRays.ray(k), thin.generatePinholeRay(s.column[k], 7, Vec2(s.u0[k], s.u1[k])), k);
      EXPECT_EQ(weight[k], thin.aperture().weight());
      EXPECT_EQ(pinholeWeight[k], thin.aperture().weight());
    }
    EXPECT_TRUE(thin.usesLensSample());
    EXPECT_FALSE(pinhole.usesLensSample());
    EXPECT_FALSE(thin.stopsRays() || pinhole.stopsRays() || thin.spectral() || pinhole.spectral());
    EXPECT_EQ(pinhole.width(), 64);
    EXPECT_EQ(pinhole.height(), 48);
  }
}

TEST(CameraInterface, RealLensPacketsAreItsOneRayRaysAndStoppedLanesWeighZero) {
  test::TempDir dir;
  json j = test::bundledSceneJson("cornell-real-lens.json");
  j["camera"]["lens"] = (test::scenesDir() / "lenses/dgauss.50mm.dat").string();
  j["render"]["resolution"] = {64, 48};
  const Scene scene = test::loadSceneJson(dir, j);
  const RealLensCamera real = *scene.realLensCamera();
  EXPECT_STREQ(real.type(), "real_lens");
  EXPECT_TRUE(real.stopsRays());
  EXPECT_FALSE(real.connects());
  int stopped = 0, passed = 0;
  // Lenses at the rim of the pupil bounds are stopped now and then; sweep them.
  for (int row = 0; row < 48; row += 5) {
    CameraSampleLanes s = lanesOf(kPacketWidth - 3, 64);
    s.row = row;
    for (int k = 0; k < kPacketWidth; ++k) s.lens0[k] = k % 2 ? 0.5f : 0.001f;
    CameraRayLanes rays;
    float weight[kPacketWidth];
    real.sampleRays(s, rays, weight);
    for (int k = 0; k < kPacketWidth; ++k) {
      float w = 0.0f;
      // (A lens that disperses traces each lane at its own wavelength.)
      const double nm = real.spectral() ? s.wavelengthNm[k] : LensSystem::kWavelengthD;
      const auto one =
          k < s.count ? real.generateRay(s.column[k], row, Vec2(s.u0[k], s.u1[k]), Vec2(s.lens0[k], s.lens1[k]), &w, nm)
                      : std::nullopt;
      if (!one) {
        EXPECT_EQ(weight[k], 0.0f) << "lane " << k;
        stopped += k < s.count;
      } else {
        EXPECT_EQ(weight[k], w) << "lane " << k;
        expectSameBits(rays.ray(k), *one, k);
        ++passed;
      }
      const CameraRay r = rays.ray(k);  // stopped lanes still hold a finite ray
      EXPECT_TRUE(std::isfinite(r.origin.x) && std::isfinite(r.direction.z)) << "lane " << k;
    }
  }
  EXPECT_GT(passed, 0);
  EXPECT_GT(stopped, 0) << "the rim of the pupil bounds stops some rays";
  // The working f-number of the exit pupil: near the lens's own f-number (a double Gauss's pupil
  // magnification is near 1, and 3 m is far from a 50 mm lens).
  const double nw = real.exitPupil().workingFNumber;
  EXPECT_GT(nw, real.lens().paraxial().fNumber * 0.8);
  EXPECT_LT(nw, real.lens().paraxial().fNumber * 1.5);
  EXPECT_TRUE(real.exitPupil().shape.isRound());
}

// The cell a sensor point lies in, as the thin lens's convention says (thin_lens_camera.h).
uint64_t cellAt(const ThinLensCamera& c, Vec2 s) {
  const ThinLensParams& p = c.params();
  const int i = int(std::floor((s.x / p.sensorWidth + 0.5) * c.width()));
  const int j = int(std::floor((0.5 - s.y / p.sensorHeight) * c.height()));
  return uint64_t(j) * uint64_t(c.width()) + uint64_t(i);
}

TEST(CameraInterface, ThinLensConnectionInvertsItsRaysWithTheImportanceOfTheCell) {
  const ThinLensCamera camera(lensParams(1.4), 64, 48);
  const ThinLensParams& p = camera.params();
  const double cellArea = (p.sensorWidth / 64) * (p.sensorHeight / 48);
  int checked = 0;
  for (int i = 1; i < 64; i += 9)
    for (int j = 2; j < 48; j += 7)
      for (const Vec2 uLens : {Vec2(0.5f), Vec2(0.1f, 0.8f), Vec2(0.93f, 0.27f)}) {
        // The ray from the middle of cell (i, j) through lens point r, and a point 2.5 along it.
        const Vec2 sensor = camera.sensorPoint(i, j, Vec2(0.5f));
        const Vec2 r = camera.aperture().sample(uLens) * float(camera.lensRadius());
        const CameraRay ray = camera.rayThrough(sensor, r);
        const Vec3 point = ray.origin + 2.5f * ray.direction;
        const auto c = camera.connect(point, uLens);
        ASSERT_TRUE(c) << i << "," << j;
        EXPECT_EQ(c->cell, cellAt(camera, sensor)) << i << "," << j;
        EXPECT_NEAR(glm::length(c->lensPoint - ray.origin), 0.0, 1e-6);
        EXPECT_NEAR(glm::dot(c->toLens, -ray.direction), 1.0, 1e-6);
        EXPECT_NEAR(c->distance, 2.5, 1e-5);
        EXPECT_NEAR(c->distance2, 6.25, 1e-4);
        // W cos^3 = w_ap S2^2 / A_cell (the light tracer's (LT)); theta the ray's angle to the axis.
        const double cosTheta = glm::dot(ray.direction, camera.forward());
        const double expected = camera.aperture().weight() * camera.imageDistance() * camera.imageDistance() /
                                (cellArea * cosTheta * cosTheta * cosTheta);
        EXPECT_NEAR(c->importance / expected, 1.0, 1e-5);
        ++checked;
      }
  EXPECT_EQ(checked, 7 * 7 * 3);
}

TEST(CameraInterface, PinholeConnectsThroughTheLensCentreWhateverTheLensSample) {
  const ThinLensCamera lens(lensParams(1.4), 64, 48);
  const PinholeCamera pinhole(lens);
  const CameraRay ray = lens.generatePinholeRay(40, 11, Vec2(0.25f, 0.75f));
  const Vec3 point = ray.origin + 4.0f * ray.direction;
  const auto a = pinhole.connect(point, Vec2(0.9f, 0.1f)), b = pinhole.connect(point, Vec2(0.2f, 0.6f));
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->cell, b->cell);
  EXPECT_EQ(a->cell, uint64_t(11) * 64 + 40);
  EXPECT_EQ(a->lensPoint, lens.params().position);
}

TEST(CameraInterface, HardPointsGiveNoConnectionOrAFiniteOne) {
  const ThinLensCamera camera(lensParams(2.0), 64, 48);
  const Vec3 centre = camera.params().position;
  EXPECT_FALSE(camera.connect(centre, Vec2(0.5f))) << "a point on the lens point: no direction";
  EXPECT_FALSE(camera.connect(centre - 3.0f * camera.forward(), Vec2(0.5f))) << "behind the lens";
  EXPECT_FALSE(camera.connect(centre + camera.forward() + 5.0f * camera.right(), Vec2(0.5f))) << "off the sensor";
  EXPECT_FALSE(camera.connect(centre + 1e-3f * camera.right(), Vec2(0.5f))) << "beside the lens, at 90 degrees";
  // Far away along the axis (1e6) the connection lands in the sensor's central cells, finitely.
  for (const float distance : {1e3f, 1e6f}) {
    const auto far = camera.connect(centre + distance * camera.forward(), Vec2(0.3f, 0.7f));
    ASSERT_TRUE(far) << distance;
    EXPECT_TRUE(std::isfinite(far->importance) && far->importance > 0.0) << distance;
    const uint64_t i = far->cell % 64, j = far->cell / 64;
    EXPECT_TRUE(i >= 31 && i <= 32 && j >= 23 && j <= 24) << distance << ": cell " << i << "," << j;
  }
}

TEST(CameraInterface, TheRegistryPicksTheDeclaredModelAndAPinholeWhereBlurIsInvisible) {
  test::TempDir dir;
  json seed = test::bundledSceneJson("cornell-seed.json");
  EXPECT_STREQ(declaredCamera(test::loadSceneJson(dir, seed))->type(), "thin_lens");
  json closed = seed;
  closed["camera"]["f_number"] = "infinity";
  EXPECT_STREQ(declaredCamera(test::loadSceneJson(dir, closed))->type(), "pinhole");
  json real = test::bundledSceneJson("cornell-real-lens.json");
  real["camera"]["lens"] = (test::scenesDir() / "lenses/dgauss.50mm.dat").string();
  EXPECT_STREQ(declaredCamera(test::loadSceneJson(dir, real))->type(), "real_lens");
  // The render's camera: the seed's lens at a thumbnail size blurs less than half a cell, so it is
  // traced as a pinhole; at its own size with its depth of field, as the thin lens.
  json thumb = seed;
  thumb["render"]["resolution"] = {8, 6};
  thumb["camera"]["f_number"] = 64.0;
  const Scene small = test::loadSceneJson(dir, thumb);
  const RenderScene thumbnail(small);
  ASSERT_FALSE(thumbnail.effects().depthOfField);
  EXPECT_STREQ(thumbnail.camera().type(), "pinhole");
  json wide = seed;
  wide["camera"]["f_number"] = 1.4;
  const Scene open = test::loadSceneJson(dir, wide);
  const RenderScene dof(open);
  ASSERT_TRUE(dof.effects().depthOfField);
  EXPECT_STREQ(dof.camera().type(), "thin_lens");
  EXPECT_TRUE(dof.camera().connects());
}

}  // namespace
}  // namespace lensfarm
