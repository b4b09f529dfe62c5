// Light sampling at the extremes, judged statistically: NEE+MIS must agree with the 2013 report's naive
// estimator (which never samples a light) for tiny, huge, edge-on and hidden lights.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

#include "common/render/render_scene.h"

#include "tests/test_support.h"

namespace lensfarm {
namespace {

using nlohmann::json;

// A floor and a back wall seen from above by a pinhole camera, lit by one quad light. quad()'s
// light faces the side of cross(e1, e2): e1 along x and e2 along z face down.
json floorScene(const json& light, int spp) {
  return {
      {"format", "lensfarm-scene/1"},
      {"camera",
       {{"type", "pinhole"},
        {"position", {0, 3, -3}},
        {"look_at", {0, 0, 0}},
        {"up", {0, 1, 0}},
        {"sensor_width", 0.1},
        {"focal_length", 0.08}}},
      {"materials",
       {{"floor", {{"type", "lambertian"}, {"albedo", 0.7}}}, {"wall", {{"type", "lambertian"}, {"albedo", 0.4}}}}},
      {"shapes", json::array({{{"type", "quad"},
                               {"corner", {-2, 0, -2}},
                               {"edge1", {0, 0, 4}},
                               {"edge2", {4, 0, 0}},
                               {"material", "floor"}},
                              {{"type", "quad"},
                               {"corner", {-2, 0, 2}},
                               {"edge1", {4, 0, 0}},
                               {"edge2", {0, 3, 0}},
                               {"material", "wall"}}})},
      {"lights", json::array({light})},
      {"render", {{"resolution", {12, 12}}, {"samples_per_pixel", spp}, {"max_bounces", 2}}},
  };
}

json quad(std::vector<double> corner, std::vector<double> e1, std::vector<double> e2, double radiance) {
  return {{"type", "quad"}, {"corner", corner},     {"edge1", e1},
          {"edge2", e2},    {"radiance", radiance}, {"visible_to_camera", false}};
}

struct Case {
  const char* name;
  json light;
  int neeSpp, naiveSpp;
};

TEST(LightSampling, NeeMisAgreesWithTheNaiveEstimatorAtTheExtremes) {
  const std::vector<Case> cases = {
      {"tiny", quad({-0.005, 1.5, -0.005}, {0.01, 0, 0}, {0, 0, 0.01}, 3e4), 16, 8192},
      {"huge", quad({-500, 50, -500}, {1000, 0, 0}, {0, 0, 1000}, 0.5), 16, 64},
      {"edge-on", quad({-1, 0.0, 1.0}, {2, 0, 0}, {0, 1.5, 0}, 3.0), 16,
       256},  // stands on the floor, faces the camera side
  };
  for (const Case& c : cases) {
    test::TempDir dir;
    json scene = floorScene(c.light, c.neeSpp);
    const Scene nee = test::loadSceneJson(dir, scene, "nee.json");
    scene["render"]["integrator"] = "naive";
    scene["render"]["samples_per_pixel"] = c.naiveSpp;
    const Scene naive = test::loadSceneJson(dir, scene, "naive.json");
    const test::ImageStatistics a = test::renderStatistics(nee, 8), b = test::renderStatistics(naive, 8);
    for (double m : a.mean) ASSERT_TRUE(std::isfinite(m)) << c.name;
    EXPECT_GT(a.imageMean, 0.0) << c.name;
    const double se = std::hypot(a.imageMeanError, b.imageMeanError);
    EXPECT_LE(std::abs(a.imageMean - b.imageMean), 3.0 * se + 1e-12)
        << c.name << ": NEE " << a.imageMean << " vs naive " << b.imageMean << " +- " << se;
    // (No per-pixel test here: the naive estimator's per-pixel values are far too heavy-tailed
    // for 8 renders to estimate their variance; the image means above are the judge.)
  }
}

TEST(LightSampling, ALightFacingAwayOrBehindTheFloorLightsNothing) {
  for (const json& light : {quad({-0.5, 3.5, -0.5}, {0, 0, 1}, {1, 0, 0}, 5.0),      // above all, faces up
                            quad({-0.5, -0.5, -0.5}, {0, 0, 1}, {1, 0, 0}, 5.0)}) {  // under the floor, faces it
    for (const char* integrator : {"nee_mis", "naive"}) {
      test::TempDir dir;
      json scene = floorScene(light, 8);
      scene["render"]["integrator"] = integrator;
      const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
      for (float v : r.image.rgb) ASSERT_EQ(v, 0.0f) << integrator << " " << light.dump();
      EXPECT_EQ(r.stats.dropped, 0u);
    }
  }
}

// The packet form of the light sample reads a lane's light two ways, by the number of emitting
// triangles: selects among up to 4 (2 here), gathers beyond (6: chosen by counting cdf entries,
// 12: by a search), or each lane's own choice by a light tree; lanes near their light take its
// point by solid angle, the others by area. Each must give every lane the one-sample form's bits.
TEST(LightSampling, PacketFormGivesEachLaneTheOneSampleBitsForAnyNumberOfLights) {
  for (const char* tree : {"off", "on"})
    for (int quads : {1, 3, 6}) {  // 2, 6 and 12 emitting triangles
      SCOPED_TRACE(std::string("tree ") + tree);
      // The first lamp low enough that the floor lies within its reach (LightSampler::bySolidAngle).
      json scene = floorScene(quad({-0.5, 1.0, -0.5}, {1, 0, 0}, {0, 0, 1}, 2.0), 1);
      for (int q = 1; q < quads; ++q)  // more quads of other sizes, heights and radiances
        scene["lights"].push_back(
            quad({-1.5 + 0.4 * q, 1.0 + 0.2 * q, -1.0}, {0.3 * q, 0, 0}, {0, 0.1 * q, 0.5}, 1.0 + q));
      scene["render"]["light_tree"] = tree;
      test::TempDir dir;
      const Scene loaded = test::loadSceneJson(dir, scene);
      const RenderScene rs(loaded);
      ASSERT_EQ(rs.lights().size(), size_t(2 * quads));
      ASSERT_EQ(rs.lights().usesTree(), std::string(tree) == "on");

      std::mt19937 rng(quads);
      std::uniform_real_distribution<float> u01(0.0f, 1.0f), coord(-2.0f, 2.0f);
      int near = 0, far = 0;
      for (int round = 0; round < 50; ++round) {
        LightSampleLanes lanes{};
        for (int k = 0; k < kPacketWidth; ++k) {
          lanes.found[k] = (k + round) % 5 == 0 ? 0 : -1;  // some lanes are not asked
          lanes.uChoice[k] = u01(rng), lanes.u0[k] = u01(rng), lanes.u1[k] = u01(rng);
          // Anywhere, or about a light (render space, whose origin is the camera), where many lanes
          // are near theirs.
          const auto& lights = rs.lights().triangleLights();
          const Vec3 about = round % 2 ? lights[size_t(u01(rng) * float(lights.size())) % lights.size()].centroid
                                       : Vec3(0.0f, -2.0f, 3.0f);
          const float spread = round % 2 ? 0.5f : 1.0f;
          lanes.refx[k] = about.x + spread * coord(rng), lanes.refy[k] = about.y + spread * coord(rng),
          lanes.refz[k] = about.z + spread * coord(rng);
          for (const auto& l : rs.lights().triangleLights())
            (LightSampler::bySolidAngle(l, Vec3(lanes.refx[k], lanes.refy[k], lanes.refz[k])) ? near : far) += 1;
        }
        const LightSampleLanes asked = lanes;
        rs.lights().sample(lanes);
        for (int k = 0; k < kPacketWidth; ++k) {
          if (!asked.found[k]) {
            EXPECT_EQ(lanes.found[k], 0) << quads << " quads, lane " << k << " was not asked";
            continue;
          }
          const auto one = rs.lights().sample(Vec3(asked.refx[k], asked.refy[k], asked.refz[k]), asked.uChoice[k],
                                              Vec2(asked.u0[k], asked.u1[k]));
          ASSERT_EQ(lanes.found[k] != 0, one.has_value()) << quads << " quads, lane " << k;
          if (!one) continue;
          const float packet[14] = {lanes.px[k], lanes.py[k],  lanes.pz[k],  lanes.nx[k],  lanes.ny[k],
                                    lanes.nz[k], lanes.v0x[k], lanes.v0y[k], lanes.v0z[k], lanes.margin[k],
                                    lanes.rr[k], lanes.rg[k],  lanes.rb[k],  lanes.pdf[k]};
          const float single[14] = {one->p.x,        one->p.y,        one->p.z,        one->n.x,  one->n.y,
                                    one->n.z,        one->v0.x,       one->v0.y,       one->v0.z, one->margin,
                                    one->radiance.r, one->radiance.g, one->radiance.b, one->pdf};
          EXPECT_EQ(std::memcmp(packet, single, sizeof(packet)), 0) << quads << " quads, lane " << k;
        }
      }
      EXPECT_GT(near, 100) << quads << " quads: lanes near a light";
      EXPECT_GT(far, 100);
    }
}

TEST(ImageStatisticsCheck, TellsAnUnbiasedEstimateFromABiasedOne) {
  // The statistical judge itself: two seeds' worth of the same estimator agree; a 5 % brighter
  // light does not.
  test::TempDir dir;
  json scene = floorScene(quad({-0.5, 1.5, -0.5}, {1, 0, 0}, {0, 0, 1}, 5.0), 16);
  const test::ImageStatistics a = test::renderStatistics(test::loadSceneJson(dir, scene, "a.json"), 16);
  scene["render"]["samples_per_pixel"] = 24;  // another sample count: another estimate of the same image
  const test::ImageStatistics b = test::renderStatistics(test::loadSceneJson(dir, scene, "b.json"), 16);
  EXPECT_GE(test::agreementFraction(a, b), 0.995) << "identical estimators must agree";
  scene["lights"][0]["radiance"] = 5.25 * 1.2;
  const test::ImageStatistics c = test::renderStatistics(test::loadSceneJson(dir, scene, "c.json"), 16);
  EXPECT_LT(test::agreementFraction(a, c), 0.995) << "a 26 % brighter light must be noticed";
}

}  // namespace
}  // namespace lensfarm
