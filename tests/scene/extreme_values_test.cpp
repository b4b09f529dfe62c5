// Extreme values (docs/numerics.md): every lens field, the resolution, samples per pixel, the
// bounce limit and every colour (albedo, reflectance, emission, radiance) at 0, a denormal,
// 1e-30, 1e30, the largest float, beyond it, an overflowing literal and NaN / Inf written as
// strings. Each is either refused with an error naming its field, or renders a finite,
// non-negative image that is also correct where it can be checked (a radiance of 1e30 gives 1e30
// times the image of radiance 1). Never a crash: an f-number of 1e-20 used to abort the whole
// process inside Embree (exit 134). The command line's side is in extreme_values_cli_test.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/film/exposure.h"
#include "common/render/integrator.h"
#include "common/scene/scene_loader.h"
#include "common/util/error.h"
#include "tests/scene/extreme_values_cases.h"
#include "tests/scene/scene_error_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;
using test::Case;
using test::kFloatMax;
using test::kNoError;
using test::Outcome;
using test::sceneText;

std::string describe(const Case& c) { return c.field + " = " + c.value; }

class ExtremeValues : public test::SceneErrorTest {
 protected:
  ExtremeValues() : SceneErrorTest("extreme.json") {}

  // The error names the field: "<file>: <field>: ..." or "<file>: <field>[i]: ...".
  ::testing::AssertionResult refusedNaming(const std::string& message, const std::string& field) const {
    const std::string prefix = sceneFile().string() + ": " + field;
    if (message.rfind(prefix, 0) == 0 && message.size() > prefix.size() &&
        (message[prefix.size()] == ':' || message[prefix.size()] == '['))
      return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "message \"" << message << "\" does not name " << field;
  }

  // Loads (and renders, if the case says so) one case; every check of the table.
  void check(const Case& c) {
    SCOPED_TRACE(describe(c));
    const std::string text = sceneText(c, c.value);
    dir_.write("extreme.json", text);
    if (c.outcome == Outcome::kRefused) {
      const std::string message = loadError();
      EXPECT_TRUE(refusedNaming(message, c.namedAs.empty() ? c.field : c.namedAs));
      // The field given is named in the message even where another one is blamed.
      std::string key = c.field.substr(c.field.rfind('.') + 1);
      key = key.substr(0, key.find('['));
      EXPECT_NE(message.find(key), std::string::npos) << message;
      return;
    }
    Scene scene;
    try {
      scene = loadScene(sceneFile());
    } catch (const InputError& e) {
      FAIL() << "refused: " << e.what();
    }
    if (c.outcome == Outcome::kLoads) return;
    const test::Rendered r = test::renderScene(scene);
    EXPECT_EQ(r.stats.dropped, 0u) << "samples that overflowed or were NaN";
    bool black = true;
    for (float v : r.image.rgb) {
      ASSERT_TRUE(std::isfinite(v)) << v;
      ASSERT_GE(v, 0.0f);
      black = black && v == 0.0f;
    }
    if (c.outcome == Outcome::kBlack) {
      EXPECT_TRUE(black);
      return;
    }
    if (c.outcome == Outcome::kFinite) return;
    EXPECT_FALSE(black) << "a render that should show the scene is black";
    if (c.ratio > 0.0) {
      dir_.write("reference.json", sceneText(c, "1"));
      const test::Rendered ref = test::renderScene(loadScene(dir_ / "reference.json"));
      for (int k = 0; k < 3; ++k) {
        ASSERT_GT(ref.mean[k], 0.0);
        EXPECT_NEAR(r.mean[k] / ref.mean[k] / c.ratio, 1.0, 1e-5) << "channel " << k;
      }
    }
  }
};

// The values every field is tried with, as JSON text (with kFloatMax, from extreme_values_cases.h).
const std::string kDenormal = "5e-324", kFloatDenormal = "1e-40", kAboveFloat = "3.5e38", kOverflow = "1e999",
                  kNaN = "\"NaN\"", kInf = "\"inf\"";

TEST_F(ExtremeValues, EveryLensFieldAtEveryExtremeIsRefusedNamingItOrRendersSanely) {
  const json angle = {{"camera", {{"focal_length", nullptr}, {"angle_of_view", 50}}}};
  const std::vector<Case> cases = {
      // N: below 0.5 no lens in air exists (N = 1 / (2 NA), NA <= 1); 1e-20 aborted in Embree.
      {"camera.f_number", "0", Outcome::kRefused},
      {"camera.f_number", "-0.0", Outcome::kRefused},
      {"camera.f_number", kDenormal, Outcome::kRefused},
      {"camera.f_number", "1e-30", Outcome::kRefused},
      {"camera.f_number", "1e-20", Outcome::kRefused},
      {"camera.f_number", "0.4999", Outcome::kRefused},
      {"camera.f_number", "0.5", Outcome::kRenders},
      {"camera.f_number", "1e30", Outcome::kRenders},
      {"camera.f_number", kFloatMax, Outcome::kRenders},
      {"camera.f_number", kAboveFloat, Outcome::kRenders},  // a double: R = f / (2N) is 0 in float, a pinhole
      {"camera.f_number", "1e308", Outcome::kRenders},
      {"camera.f_number", kOverflow, Outcome::kRefused},
      {"camera.f_number", kNaN, Outcome::kRefused},
      {"camera.f_number", kInf, Outcome::kRenders},  // "inf" is a pinhole, as documented
      {"camera.f_number", "\"-inf\"", Outcome::kRefused},
      // f: a denormal has no finite reciprocal; tiny ones give 180 degrees of view (the sensor is
      // blamed, with f named); huge ones are a unit mix-up.
      {"camera.focal_length", "0", Outcome::kRefused},
      {"camera.focal_length", kDenormal, Outcome::kRefused},
      {"camera.focal_length", "1e-30", Outcome::kRefused, 0.0, "camera.sensor_width"},
      {"camera.focal_length", "1e30", Outcome::kRefused},
      {"camera.focal_length", kFloatMax, Outcome::kRefused},
      {"camera.focal_length", kAboveFloat, Outcome::kRefused},
      {"camera.focal_length", kOverflow, Outcome::kRefused},
      {"camera.focal_length", kNaN, Outcome::kRefused},
      {"camera.focal_length", kInf, Outcome::kRefused},
      // A huge focal length focused far away: the aperture (R = f / 2N) would put ray origins
      // beyond what Embree accepts (this too aborted).
      {"camera.focal_length",
       "1e25",
       Outcome::kRefused,
       0.0,
       "camera.f_number",
       {{"camera", {{"sensor_width", 1e24}, {"focus_distance", 1e30}, {"f_number", 1}}}}},
      // The sensor: a field of view below 1e-6 degrees (every pixel the same direction) or of
      // 180 degrees and more is refused.
      {"camera.sensor_width", "0", Outcome::kRefused},
      {"camera.sensor_width", kDenormal, Outcome::kRefused},
      {"camera.sensor_width", "1e-30", Outcome::kRefused},
      {"camera.sensor_width", "1e-5", Outcome::kRenders},  // a 0.0055 degree telephoto
      {"camera.sensor_width", "1e30", Outcome::kRefused},
      {"camera.sensor_width", kFloatMax, Outcome::kRefused},
      {"camera.sensor_width", kAboveFloat, Outcome::kRefused},
      {"camera.sensor_width", kOverflow, Outcome::kRefused},
      {"camera.sensor_width", kNaN, Outcome::kRefused},
      {"camera.sensor_height", "0", Outcome::kRenders},  // derived: square cells
      {"camera.sensor_height", kDenormal, Outcome::kRefused},
      {"camera.sensor_height", "1e-30", Outcome::kRefused},
      {"camera.sensor_height", "1e30", Outcome::kRefused},
      {"camera.sensor_height", kAboveFloat, Outcome::kRefused},
      {"camera.sensor_height", kOverflow, Outcome::kRefused},
      {"camera.sensor_height", kInf, Outcome::kRefused},
      // S1: at or inside f is refused; any distance beyond renders (S2 tends to f).
      {"camera.focus_distance", "0", Outcome::kRefused},
      {"camera.focus_distance", kDenormal, Outcome::kRefused},
      {"camera.focus_distance", "1e-30", Outcome::kRefused},
      {"camera.focus_distance", "1e30", Outcome::kRenders},
      {"camera.focus_distance", kFloatMax, Outcome::kRenders},
      {"camera.focus_distance", kAboveFloat, Outcome::kRenders},
      {"camera.focus_distance", "1e308", Outcome::kRenders},
      {"camera.focus_distance", kOverflow, Outcome::kRefused},
      {"camera.focus_distance", kNaN, Outcome::kRefused},
      // The angle of view: [1e-6, 179.999] degrees; 1e-6 on a 0.1 sensor is a focal length of
      // 1e6, longer than the scene (the sensor is blamed, the angle named).
      {"camera.angle_of_view", "0", Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", kDenormal, Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", "1e-30", Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", "1e-6", Outcome::kRefused, 0.0, "camera.sensor_width", angle},
      {"camera.angle_of_view", "179.999", Outcome::kFinite, 0.0, "", angle},
      {"camera.angle_of_view", "1e30", Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", kAboveFloat, Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", kOverflow, Outcome::kRefused, 0.0, "", angle},
      {"camera.angle_of_view", kNaN, Outcome::kRefused, 0.0, "", angle},
  };
  for (const Case& c : cases) check(c);
}

TEST_F(ExtremeValues, ResolutionSamplesAndBounceLimitAtTheirExtremes) {
  const std::vector<Case> cases = {
      {"render.resolution[0]", "0", Outcome::kRefused, 0.0, "render.resolution"},
      {"render.resolution[1]", "1", Outcome::kRenders},  // one row: the centre line of the quad
      {"render.resolution[0]", "16384", Outcome::kRenders, 0.0, "", {{"render", {{"samples_per_pixel", 1}}}}},
      {"render.resolution[0]", "16385", Outcome::kRefused, 0.0, "render.resolution"},
      {"render.resolution[1]", "1e30", Outcome::kRefused, 0.0, "render.resolution"},
      {"render.resolution[1]", kOverflow, Outcome::kRefused, 0.0, "render.resolution"},
      {"render.resolution[1]", kNaN, Outcome::kRefused, 0.0, "render.resolution"},
      {"render.resolution[1]", "-1", Outcome::kRefused, 0.0, "render.resolution"},
      {"render.samples_per_pixel", "0", Outcome::kRefused},
      {"render.samples_per_pixel", "1", Outcome::kRenders},
      {"render.samples_per_pixel", "1099511627776", Outcome::kLoads},  // 2^40, the cap
      {"render.samples_per_pixel", "1099511627777", Outcome::kRefused},
      {"render.samples_per_pixel", "1e30", Outcome::kRefused},
      {"render.samples_per_pixel", kOverflow, Outcome::kRefused},
      {"render.samples_per_pixel", kNaN, Outcome::kRefused},
      {"render.samples_per_pixel", "-1", Outcome::kRefused},
      {"render.max_bounces", "0", Outcome::kBlack},  // the light is not visible to the camera
      {"render.max_bounces", "1024", Outcome::kRenders},
      {"render.max_bounces", "1025", Outcome::kRefused},
      {"render.max_bounces", "1e30", Outcome::kRefused},
      {"render.max_bounces", kOverflow, Outcome::kRefused},
      {"render.max_bounces", kNaN, Outcome::kRefused},
      {"render.max_bounces", "-1", Outcome::kRefused},
  };
  for (const Case& c : cases) check(c);
}

TEST_F(ExtremeValues, ColoursAreZeroOrWithinWhatTheFloatKernelCarries) {
  // Radiance and emission: 0 or [1e-30, 1e30]; albedos and reflectances: 0 or [1e-6, 1]. A
  // denormal radiance used to load and render black (the kernel flushes denormals to 0); 3.4e38
  // loaded and overflowed every sample.
  const json mirror = {{"materials", {{"white", {{"type", "mirror"}, {"albedo", nullptr}}}}}};
  const json glowing = {{"lights",
                         {{{"type", "quad"},
                           {"corner", {-0.5, -0.5, -1}},
                           {"edge1", {1, 0, 0}},
                           {"edge2", {0, 1, 0}},
                           {"radiance", 0},
                           {"visible_to_camera", false}}}}};
  const std::vector<Case> cases = {
      {"lights[0].radiance", "0", Outcome::kBlack},
      {"lights[0].radiance", kDenormal, Outcome::kRefused},
      {"lights[0].radiance", kFloatDenormal, Outcome::kRefused},
      {"lights[0].radiance", "9.9e-31", Outcome::kRefused},
      {"lights[0].radiance", "1e-30", Outcome::kRenders, 1e-30},
      {"lights[0].radiance", "1e30", Outcome::kRenders, 1e30},
      {"lights[0].radiance", "1.0001e30", Outcome::kRefused},
      {"lights[0].radiance", kFloatMax, Outcome::kRefused},
      {"lights[0].radiance", kAboveFloat, Outcome::kRefused},
      {"lights[0].radiance", kOverflow, Outcome::kRefused},
      {"lights[0].radiance", kNaN, Outcome::kRefused},
      {"lights[0].radiance", kInf, Outcome::kRefused},
      {"lights[0].radiance", "-1e-30", Outcome::kRefused},
      {"lights[0].radiance", "[1, 1e31, 1]", Outcome::kRefused},
      {"lights[0].radiance", "[1, \"nan\", 1]", Outcome::kRefused},
      {"lights[0].radiance", "[1, 1e-40, 1]", Outcome::kRefused},
      {"lights[0].radiance", "[1e30, 1e-30, 0]", Outcome::kRenders},
      {"materials.white.albedo", "0", Outcome::kBlack},
      {"materials.white.albedo", "-0.0", Outcome::kBlack},
      {"materials.white.albedo", kDenormal, Outcome::kRefused},
      {"materials.white.albedo", kFloatDenormal, Outcome::kRefused},
      {"materials.white.albedo", "1e-30", Outcome::kRefused},
      {"materials.white.albedo", "1e-6", Outcome::kRenders, 1e-6},
      {"materials.white.albedo", "1", Outcome::kRenders},
      {"materials.white.albedo", "1.0000001", Outcome::kRefused},
      {"materials.white.albedo", "1e30", Outcome::kRefused},
      {"materials.white.albedo", kAboveFloat, Outcome::kRefused},
      {"materials.white.albedo", kOverflow, Outcome::kRefused},
      {"materials.white.albedo", kNaN, Outcome::kRefused},
      // A lambertian that emits (lit by nothing else): the image is its emission.
      {"materials.white.emission", kFloatDenormal, Outcome::kRefused, 0.0, "", glowing},
      {"materials.white.emission", "1e-30", Outcome::kRenders, 1e-30, "", glowing},
      {"materials.white.emission", "1e30", Outcome::kRenders, 1e30, "", glowing},
      {"materials.white.emission", kFloatMax, Outcome::kRefused, 0.0, "", glowing},
      {"materials.white.emission", kOverflow, Outcome::kRefused, 0.0, "", glowing},
      {"materials.white.emission", kNaN, Outcome::kRefused, 0.0, "", glowing},
      {"materials.white.reflectance", kFloatDenormal, Outcome::kRefused, 0.0, "", mirror},
      {"materials.white.reflectance", "2", Outcome::kRefused, 0.0, "", mirror},
      {"materials.white.reflectance", kNaN, Outcome::kRefused, 0.0, "", mirror},
  };
  for (const Case& c : cases) check(c);
  // The refusal says the range and why.
  dir_.write("extreme.json", sceneText(cases[2], kFloatDenormal));
  const std::string message = loadError();
  EXPECT_TRUE(namesField(message, "lights[0].radiance", {"must be 0 or in [1e-30, 1e+30]", "got 1e-40", "flushes"}));
  dir_.write("extreme.json", sceneText(cases[0], "1e31"));
  EXPECT_TRUE(namesField(loadError(), "lights[0].radiance", {"overflows single precision"}));
}

TEST(ExtremeValuesExposure, TinyAndHugeImagesExposeLikeAnyOther) {
  // A uniform image of any brightness maps its mean to 1 (the 2013 report's meter, §4.7.4) or its
  // lit pixels' mean to 1 (the lit meter), also where the factor is beyond float (a denormal
  // image) or the value is near the top of float: Reinhard gives 0.5.
  for (const ExposureMeter meter : {ExposureMeter::kMean, ExposureMeter::kLit}) {
    const double value = 1.0;
    const double toned = value / (1.0 + value), srgb = 1.055 * std::pow(toned, 1 / 2.4) - 0.055;
    const uint8_t expected = uint8_t(std::lround(srgb * 255));
    for (float v : {1e-45f, 1e-40f, 1e-38f, 1.0f, 1e30f, 3e38f, std::numeric_limits<float>::max()}) {
      Image image{2, 2, std::vector<float>(12, v)};
      const double scale = exposureScale(image, meter);
      EXPECT_TRUE(std::isfinite(scale) && scale > 0.0) << v;
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{0.0, ToneMap::kReinhard, meter}))
        EXPECT_EQ(b, expected) << v;
      // +-64 stops on top: white or black, never NaN (which lround would turn into anything).
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{64.0, ToneMap::kReinhard, meter})) EXPECT_EQ(b, 255) << v;
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{-64.0, ToneMap::kClamp, meter})) EXPECT_EQ(b, 0) << v;
    }
  }
  // One huge pixel among dark ones: the mean is finite, the huge pixel white, the others dark.
  Image mixed{2,
              1,
              {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
               1.0f, 1.0f, 1.0f}};
  EXPECT_TRUE(std::isfinite(autoExposureScale(mixed)));
  const auto rgb = exposeToSrgb8(mixed, ExposureSettings{0.0, ToneMap::kReinhard});
  EXPECT_GT(rgb[0], 200);
  EXPECT_EQ(rgb[3], 0);
}

TEST(ExtremeValuesBounces, ABounceLimitAbove255IsHonoured) {
  // A closed box whose walls emit 1 and reflect a = 0.99: every path of the naive estimator sees
  // exactly 1 + a + ... + a^B (every scattered ray hits an emitter). B = 300 must give that sum,
  // 95.1, not the 92.4 of B = 255 at which paths used to be cut (256 segments).
  const double a = 0.99;
  auto series = [a](int b) {
    double s = 0.0;
    for (int k = 0; k <= b; ++k) s += std::pow(a, k);
    return s;
  };
  ASSERT_GT(series(300) / series(255), 1.02) << "the test must tell the two apart";
  for (int b : {255, 300, 1024}) {
    test::TempDir dir;
    json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", a}, {"emission", 1.0}}, 4, 2, b);
    scene["render"]["integrator"] = "naive";
    scene["render"]["russian_roulette"] = "off";  // exactly: roulette would end paths by chance
    const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c] / series(b), 1.0, 1e-4) << "B = " << b;
    EXPECT_GE(pathSegmentLimit(b), 2 * (b + 1)) << "room for B counted bounces and as many mirror reflections";
  }
  // The production estimator, with its noise (the default roulette's among it: 16,384 paths keep it
  // near 0.5 %): B = 300 stays measurably above B = 255's value.
  test::TempDir dir;
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", a}, {"emission", 1.0}}, 16, 64, 300);
  const test::Rendered r = test::renderScene(test::loadSceneJson(dir, scene));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.mean[c] / series(300), 1.0, 0.01);
  EXPECT_EQ(pathSegmentLimit(2), 256) << "small bounce limits keep the limit they always had";
}

}  // namespace
}  // namespace lensfarm
