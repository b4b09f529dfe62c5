// Thin walls (BsdfTraits::thinWall: a smooth thin-walled glTF transmission, a dielectric pane):
// light passes straight through them with their tint, so a pane under a point light casts a
// shadow of the tint's darkness, never a black one. Checked against the analytic straight
// transmittance (the principled model's C (1 - m) t (1 - F_d), the pane's tint (1 - 2R/(1+R))),
// and the estimator's honesty against a second one: light sampling with MIS and the naive
// estimator, which reaches the light only through the wall, agree on an area light behind a pane.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/material/fresnel.h"
#include "common/scene/effects.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

// A white floor lit by a point light 2 above the origin, seen from the side; with `pane`, a 1 x 1
// horizontal wall of that material at height 1 between them, outside every camera ray to the
// floor near the origin.
json paneScene(const json* pane, int bounces = 1) {
  json j = {{"format", "lensfarm-scene/1"},
            {"render", {{"resolution", {32, 32}}, {"samples_per_pixel", 16}, {"max_bounces", bounces}}},
            {"camera", {{"type", "pinhole"}, {"position", {0, 3, 4}}, {"look_at", {0, 0, 0}}, {"angle_of_view", 12}}},
            {"materials", {{"floor", {{"type", "lambertian"}, {"albedo", 0.5}}}}},
            {"shapes",
             {{{"type", "quad"},
               {"material", "floor"},
               {"corner", {-5, 0, -5}},
               {"edge1", {0, 0, 10}},
               {"edge2", {10, 0, 0}}}}},
            {"lights", {{{"type", "point"}, {"position", {0, 2, 0}}, {"intensity", 8}}}}};
  if (pane) {
    j["materials"]["pane"] = *pane;
    j["shapes"].push_back({{"type", "quad"},
                           {"material", "pane"},
                           {"corner", {-0.5, 1, -0.5}},
                           {"edge1", {0, 0, 1}},
                           {"edge2", {1, 0, 0}}});
  }
  return j;
}

// The mean of the 8 x 8 pixels at the image's centre (the floor around the origin), per channel.
Spectrum centre(const test::Rendered& r) {
  Spectrum sum(0.0f);
  for (int y = 12; y < 20; ++y)
    for (int x = 12; x < 20; ++x) sum += r.image.at(x, y);
  return sum / 64.0f;
}

TEST(ThinWalls, APaneUnderAPointLightCastsAShadowOfItsTint) {
  const test::TempDir dir;
  const Spectrum tint(0.8f, 0.6f, 0.4f);
  const Scene open = test::loadSceneJson(dir, paneScene(nullptr));
  const Spectrum lit = centre(test::renderScene(open));
  ASSERT_GT(lit.g, 0.0f);
  // At the centre the light crosses the pane almost along its normal (within 0.25 rad).
  float cosT;
  const float r0 = fresnelDielectric(1.0f, 1.5f, cosT);
  const struct {
    json material;
    Spectrum expected;  // straight transmittance at normal incidence
  } cases[] = {
      // glTF's thin-walled transmission: C (1 - F_d(0)) with the Schlick f0 of ior 1.5, 0.04.
      {{{"type", "principled"},
        {"base_color", {0.8, 0.6, 0.4}},
        {"metallic", 0},
        {"roughness", 0},
        {"transmission", 1}},
       tint * 0.96f},
      // A dielectric pane: tint (1 - 2R / (1 + R)).
      {{{"type", "dielectric"}, {"transmittance", {0.8, 0.6, 0.4}}, {"ior", 1.5}, {"thin_walled", true}},
       tint * (1.0f - 2.0f * r0 / (1.0f + r0))},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.material.dump());
    const Scene shaded = test::loadSceneJson(dir, paneScene(&c.material));
    EXPECT_TRUE(analyzeEffects(shaded, shaded.camera()).thinWalls);
    const Spectrum behind = centre(test::renderScene(shaded));
    for (int ch = 0; ch < 3; ++ch) {
      // Off the axis the Fresnel term grows a little: within 2 % of the normal-incidence value.
      EXPECT_NEAR(behind[ch] / lit[ch], c.expected[ch], 0.02f * c.expected[ch]) << "channel " << ch;
    }
  }
}

TEST(ThinWalls, ARoughOrSolidWallIsNoThinWall) {
  // Only the smooth thin-walled transmission is a straight crossing; a scene without one keeps
  // the surface tracers (it pays nothing).
  const test::TempDir dir;
  for (const json& m :
       {json{{"type", "principled"}, {"roughness", 0.5}, {"transmission", 1}, {"metallic", 0}},
        json{{"type", "principled"}, {"roughness", 0}, {"transmission", 1}, {"metallic", 0}, {"thin_walled", false}},
        json{{"type", "dielectric"}, {"ior", 1.5}}, json{{"type", "lambertian"}, {"albedo", 0.5}}}) {
    const Scene s = test::loadSceneJson(dir, paneScene(&m));
    EXPECT_FALSE(analyzeEffects(s, s.camera()).thinWalls) << m.dump();
  }
}

TEST(ThinWalls, LightSamplingAndTheNaiveEstimatorAgreeThroughAPane) {
  // An area light above a tinted pane lights a floor; the naive estimator reaches the light only
  // by paths that cross the pane, light sampling by shadow rays across it, each weighed by MIS
  // against the other: the same image.
  const test::TempDir dir;
  json pane = {{"type", "principled"},
               {"base_color", {0.9, 0.5, 0.3}},
               {"metallic", 0},
               {"roughness", 0},
               {"transmission", 0.8}};
  json j = paneScene(&pane, 3);
  j["render"]["resolution"] = {12, 12};
  j["render"]["samples_per_pixel"] = 256;
  j["lights"] = {
      {{"type", "quad"}, {"corner", {-0.5, 2, -0.5}}, {"edge1", {1, 0, 0}}, {"edge2", {0, 0, 1}}, {"radiance", 10}}};
  j["camera"]["angle_of_view"] = 20;
  Scene mis = test::loadSceneJson(dir, j);
  j["render"]["integrator"] = "naive";
  Scene naive = test::loadSceneJson(dir, j);
  const test::ImageStatistics a = test::renderStatistics(mis, 16), b = test::renderStatistics(naive, 16);
  EXPECT_NEAR(a.imageMean, b.imageMean, 4.0 * std::hypot(a.imageMeanError, b.imageMeanError));
  EXPECT_GE(test::agreementFraction(a, b), 0.99);
  // And the pane does not turn the shadow black: the floor under it is lit.
  EXPECT_GT(a.imageMean, 0.0);
}

}  // namespace
}  // namespace lensfarm
