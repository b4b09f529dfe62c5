// A camera with a real lens (camera/real_lens_camera.h): the focus, the irradiance weights and
// the pupil sampling, checked by tracing its rays; the scene field that asks for it; and a render
// through it that does not depend on the thread count.
#include "common/camera/real_lens_camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

json realLensScene(double focus = 2.9, double fNumber = 2.8) {
  json scene = test::bundledSceneJson("cornell-real-lens.json");
  scene["camera"]["lens"] = (test::scenesDir() / "lenses/dgauss.50mm.dat").string();
  scene["camera"]["focus_distance"] = focus;
  scene["camera"]["f_number"] = fNumber;
  return scene;
}

// The same at side x side pixels and `spp` samples, for renders.
json smallRealLensScene(int side, uint64_t spp) {
  json scene = realLensScene();
  scene["render"]["resolution"] = {side, side};
  scene["render"]["samples_per_pixel"] = spp;
  return scene;
}

// The RMS spread, across the plane `distance` in front of the camera, of the rays from one point
// of the sensor's central cell: the blur of that plane's points.
double spreadAt(const RealLensCamera& camera, const Scene& scene, double distance) {
  const Vec3 forward = scene.camera().forward();
  DVec3 sum(0.0), sum2(0.0);
  int n = 0;
  for (int a = 0; a < 24; ++a)
    for (int b = 0; b < 24; ++b) {
      float weight = 0.0f;
      const auto ray = camera.generateRay(scene.render.width / 2, scene.render.height / 2, Vec2(0.5f),
                                          Vec2((float(a) + 0.5f) / 24.0f, (float(b) + 0.5f) / 24.0f), &weight);
      if (!ray) continue;
      const double t = (distance - double(glm::dot(ray->origin, forward))) / double(glm::dot(ray->direction, forward));
      const DVec3 p = DVec3(ray->origin) + t * DVec3(ray->direction);
      sum += p, sum2 += p * p, ++n;
    }
  EXPECT_GT(n, 100);
  const DVec3 mean = sum / double(n), var = sum2 / double(n) - mean * mean;
  return std::sqrt(std::max(0.0, var.x + var.y + var.z));
}

TEST(RealLensCamera, APointAtTheFocusDistanceIsSharperThanAtHalfOrTwiceIt) {
  test::TempDir dir;
  for (const double focus : {1.5, 2.9, 6.0}) {
    const Scene scene = test::loadSceneJson(dir, realLensScene(focus));
    const RealLensCamera camera = *scene.realLensCamera();
    const double atFocus = spreadAt(camera, scene, focus);
    EXPECT_LT(atFocus, 0.25 * spreadAt(camera, scene, 0.5 * focus)) << focus;
    EXPECT_LT(atFocus, 0.25 * spreadAt(camera, scene, 2.0 * focus)) << focus;
    // Closing the stop deepens the focus: the blur at twice the distance shrinks with the pupil.
    const Scene closed = test::loadSceneJson(dir, realLensScene(focus, 11.0));
    EXPECT_LT(spreadAt(*closed.realLensCamera(), closed, 2.0 * focus), 0.5 * spreadAt(camera, scene, 2.0 * focus));
  }
}

TEST(RealLensCamera, WeightsAverageOneAtTheCentreAndFallTowardTheCorners) {
  test::TempDir dir;
  const Scene scene = test::loadSceneJson(dir, realLensScene());
  const RealLensCamera camera = *scene.realLensCamera();
  // The mean weight of a cell's rays (a stopped ray weighs 0): 1 at the centre by definition,
  // less toward a corner (the lens's relative illumination: vignetting and cos^4).
  const auto meanWeight = [&](int i, int j) {
    double sum = 0.0;
    const int n = 64;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        float w = 0.0f;
        if (camera.generateRay(i, j, Vec2(0.5f), Vec2((float(a) + 0.5f) / n, (float(b) + 0.5f) / n), &w)) sum += w;
      }
    return sum / (n * n);
  };
  const int w = scene.render.width, h = scene.render.height;
  const double centre = meanWeight(w / 2, h / 2), corner = meanWeight(0, 0), edge = meanWeight(w / 2, 0);
  EXPECT_NEAR(centre, 1.0, 0.02);
  EXPECT_LT(corner, edge);
  EXPECT_LT(edge, centre);
  EXPECT_GT(corner, 0.05) << "the sensor lies within the lens's image circle";
  // The pupil bounds keep most sampled rays useful, and the effect line says how many: its coarse
  // estimate (4096 rays) agrees with the fine one (65536).
  const double passing = camera.passingFraction();
  EXPECT_GT(passing, 0.5);
  const RenderScene rs(scene);
  std::string reason;
  for (const auto& d : rs.effects().decisions)
    if (d.effect == "real lens") reason = d.reason;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(reason, m, std::regex(R"(; ([0-9.]+) % of them get through)"))) << reason;
  EXPECT_NEAR(std::stod(m[1]) / 100.0, passing, 0.03) << reason;
}

TEST(RealLensCamera, TheSceneFieldsAreCheckedNamingTheField) {
  test::TempDir dir;
  const auto error = [&](const json& scene) {
    try {
      test::loadSceneJson(dir, scene);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  json wide = realLensScene();
  wide["camera"]["f_number"] = 1.2;
  EXPECT_NE(error(wide).find("camera.f_number"), std::string::npos) << error(wide);
  EXPECT_NE(error(wide).find("f/2.03"), std::string::npos) << error(wide);
  json missing = realLensScene();
  missing["camera"]["lens"] = "no-such-lens.dat";
  EXPECT_NE(error(missing).find("camera.lens"), std::string::npos) << error(missing);
  json close = realLensScene(0.05);
  EXPECT_NE(error(close).find("camera.focus_distance"), std::string::npos) << error(close);
  json typo = realLensScene();
  typo["camera"]["focal_length"] = 0.05;  // the lens sets it
  EXPECT_NE(error(typo).find("focal_length"), std::string::npos) << error(typo);
  json bad = realLensScene();
  bad["camera"]["lens"] = dir.write("bad.dat", "50 5 1.5 20\n").string();
  EXPECT_NE(error(bad).find("aperture stop"), std::string::npos) << error(bad);
}

TEST(RealLensCamera, ARenderThroughItIsTheSameForAnyThreadCount) {
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, smallRealLensScene(48, 4));
  const test::Rendered one = test::renderScene(s, 1), two = test::renderScene(s, 2);
  EXPECT_TRUE(one.image.rgb == two.image.rgb);
  EXPECT_EQ(one.stats.paths, 48u * 48u * 4u) << "a stopped ray is a path too";
  EXPECT_GT(one.mean[0] + one.mean[1] + one.mean[2], 0.0);
}

// The thin lens's bladed aperture is a scene field too (thin_lens only), checked naming it.
TEST(ApertureFields, BladesAndRotationAreReadAndChecked) {
  test::TempDir dir;
  json scene = test::minimalSceneJson();
  scene["camera"]["type"] = "thin_lens";
  scene["camera"]["f_number"] = 2.8;
  scene["camera"]["aperture_blades"] = 6;
  scene["camera"]["aperture_rotation"] = 30;
  const Scene s = test::loadSceneJson(dir, scene);
  EXPECT_EQ(s.cameraParams.apertureBlades, 6);
  EXPECT_DOUBLE_EQ(s.cameraParams.apertureRotation, 30.0);
  scene["camera"]["aperture_blades"] = 2;
  try {
    test::loadSceneJson(dir, scene);
    ADD_FAILURE() << "2 blades make no aperture";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.aperture_blades"), std::string::npos) << e.what();
  }
}

// The lanes whose rays get out of the lens are traced as one packet: the same bits as tracing each
// path alone (integrator.h's promise for packets, kept with lanes taken out).
TEST(RealLensCamera, PacketsOfTheLanesThatGetOutGiveTheSingleRaysBits) {
  test::TempDir dir;
  const Scene s = test::loadSceneJson(dir, smallRealLensScene(40, 8));
  const RenderScene rs(s);
  SensorBuffer packets, singles;
  PathStats a, b;
  ASSERT_TRUE(renderUnit(rs, unitAt(0, 8, 8), packets, a, nullptr, RayGrouping::kPackets));
  ASSERT_TRUE(renderUnit(rs, unitAt(0, 8, 8), singles, b, nullptr, RayGrouping::kSingleRays));
  EXPECT_TRUE(packets.sums == singles.sums);
  EXPECT_EQ(a.paths, b.paths);
  EXPECT_EQ(a.rays, b.rays);
}

}  // namespace
}  // namespace lensfarm
