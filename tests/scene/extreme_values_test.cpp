// Extreme values (docs/numerics.md): every lens field, the resolution, samples per pixel, the
// bounce limit and every colour (albedo, reflectance, emission, radiance) at 0, a denormal,
// 1e-30, 1e30, the largest float, beyond it, an overflowing literal and NaN / Inf written as
// strings. Each is either refused with an error naming its field (and, on the command line, the
// flag, with exit code 2), or renders a finite, non-negative image that is also correct where it
// can be checked (a radiance of 1e30 gives 1e30 times the image of radiance 1). Never a crash: an
// f-number of 1e-20 used to abort the whole process inside Embree (exit 134).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "film/exposure.h"
#include "film/image_io.h"
#include "render/integrator.h"
#include "scene/scene_loader.h"
#include "scene_error_fixture.h"
#include "test_support.h"
#include "util/error.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::kNoError;

// What a case must give.
enum class Outcome {
  kRefused,  // an InputError whose field is the case's (or `namedAs`)
  kRenders,  // a finite, non-negative image that is not black
  kBlack,    // a finite image that is exactly black (a zero albedo or radiance)
  kFinite,   // a finite, non-negative image, which may be black (a 180 degree view past the quad)
  kLoads,    // loads (too costly to render in a test: 2^40 samples per pixel)
};

struct Case {
  std::string field;  // "camera.f_number", "lights[0].radiance", ...: the JSON path as errors spell it
  std::string value;  // JSON text
  Outcome outcome;
  // kRenders: the image mean must be `ratio` times the mean of the same scene with the field at
  // 1 (colours are linear; same random numbers), within float rounding. 0: not checked.
  double ratio = 0.0;
  std::string namedAs = "";  // kRefused: the field the error names, when another field carries the fault
  json patch = json::object();  // merged into the base scene first (null removes a field)
};

// The minimal scene (a 2 x 2 lit quad 3 units in front of the camera) on a thin lens, at 8 x 8
// pixels and 2 samples per pixel.
json baseScene() {
  json j = test::minimalSceneJson();
  j["camera"]["type"] = "thin_lens";
  j["camera"]["f_number"] = 2;
  j["render"]["resolution"] = {8, 8};
  j["render"]["samples_per_pixel"] = 2;
  return j;
}

// "camera.f_number" -> "/camera/f_number"; "lights[0].radiance" -> "/lights/0/radiance".
json::json_pointer pointerOf(const std::string& field) {
  std::string p = "/";
  for (char c : field) {
    if (c == '.' || c == '[') p += '/';
    else if (c != ']') p += c;
  }
  return json::json_pointer(p);
}

// The scene text with `field` set to the JSON text `value` (which may be a literal JSON itself
// cannot hold, such as 1e999).
std::string sceneText(const Case& c, const std::string& value) {
  json j = baseScene();
  j.merge_patch(c.patch);
  j[pointerOf(c.field)] = "@VALUE@";
  std::string text = j.dump(2);
  const std::string placeholder = "\"@VALUE@\"";
  text.replace(text.find(placeholder), placeholder.size(), value);
  return text;
}

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

// The values every field is tried with, as JSON text.
const std::string kDenormal = "5e-324", kFloatDenormal = "1e-40", kFloatMax = "3.4028234663852886e38",
                  kAboveFloat = "3.5e38", kOverflow = "1e999", kNaN = "\"NaN\"", kInf = "\"inf\"";

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
      {"camera.focal_length", "1e25", Outcome::kRefused, 0.0, "camera.f_number",
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
  const json glowing = {{"lights", {{{"type", "quad"}, {"corner", {-0.5, -0.5, -1}}, {"edge1", {1, 0, 0}},
                                     {"edge2", {0, 1, 0}}, {"radiance", 0}, {"visible_to_camera", false}}}}};
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
  // A uniform image of any brightness maps its mean to 1 (the seed's meter, §4.7.4) or its
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
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{0.0, ToneMap::kReinhard, meter})) EXPECT_EQ(b, expected) << v;
      // +-64 stops on top: white or black, never NaN (which lround would turn into anything).
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{64.0, ToneMap::kReinhard, meter})) EXPECT_EQ(b, 255) << v;
      for (uint8_t b : exposeToSrgb8(image, ExposureSettings{-64.0, ToneMap::kClamp, meter})) EXPECT_EQ(b, 0) << v;
    }
  }
  // One huge pixel among dark ones: the mean is finite, the huge pixel white, the others dark.
  Image mixed{2, 1, {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                     1.0f, 1.0f, 1.0f}};
  EXPECT_TRUE(std::isfinite(autoExposureScale(mixed)));
  const auto rgb = exposeToSrgb8(mixed, ExposureSettings{0.0, ToneMap::kReinhard});
  EXPECT_GT(rgb[0], 200);
  EXPECT_EQ(rgb[3], 0);
}

std::string cli() { return test::cliPath().string(); }

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

TEST(ExtremeValuesBounces, ALongPathWithLightSamplingPassesTheFarmsCountersCheck) {
  // Through the real program (its in-process coordinator checks each unit's counters): B = 1024
  // with light sampling casts about two rays per bounce, ~1,900 per path in this box, where a
  // fixed 1024-rays-per-path bound refused every unit and the render never ended.
  test::TempDir dir;
  json scene = test::closedBoxSceneJson({{"type", "lambertian"}, {"albedo", 0.99}, {"emission", 1.0}}, 4, 2, 1024);
  scene["render"]["russian_roulette"] = "off";
  const auto file = dir.path() / "long.json";
  std::ofstream(file) << scene.dump();
  const auto out = dir.path() / "long.exr";
  const test::ProcessResult r = test::runProcess({cli(), "render", file.string(), "-o", out.string()}, 300.0);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err.find("refused"), std::string::npos) << r.err;
  const Image image = readExr(out);
  double sum = 0.0;
  for (float v : image.rgb) sum += v;
  const double mean = sum / double(image.rgb.size());
  // 1 + a + ... + a^1024 = (1 - a^1025) / (1 - a), within the noise of 32 light-sampled paths.
  EXPECT_NEAR(mean / ((1.0 - std::pow(0.99, 1025)) / 0.01), 1.0, 0.05);
}

// ---- the real process: refusals exit 2 naming the field or flag; nothing aborts ---------------

std::string withValue(const std::string& field, const std::string& value, const json& patch = json::object()) {
  return sceneText(Case{field, value, Outcome::kRefused, 0.0, "", patch}, value);
}

TEST(ExtremeValuesCli, ExtremeScenesAndFlagsExitTwoNamingTheFieldAndNeverAbort) {
  struct CliCase {
    std::string name;
    std::string sceneText;
    std::vector<std::string> flags;
    std::string mustName;
  };
  const std::string good = withValue("camera.f_number", "2");
  const std::vector<CliCase> cases = {
      {"f-number 1e-20 (aborted in Embree)", withValue("camera.f_number", "1e-20"), {}, "camera.f_number"},
      {"an aperture of 5e24", withValue("camera.focal_length", "1e25", {{"camera", {{"sensor_width", 1e24}, {"focus_distance", 1e30}, {"f_number", 1}}}}),
       {}, "camera.f_number"},
      {"a denormal radiance", withValue("lights[0].radiance", "1e-40"), {}, "lights[0].radiance"},
      {"the largest float as radiance", withValue("lights[0].radiance", kFloatMax), {}, "lights[0].radiance"},
      {"a 1e-30 sensor", withValue("camera.sensor_width", "1e-30"), {}, "camera.sensor_width"},
      {"--max-bounces 1e30", good, {"--max-bounces", "1e30"}, "--max-bounces"},
      {"--spp 0", good, {"--spp", "0"}, "--spp"},
      {"--spp 1e30", good, {"--spp", "1e30"}, "--spp"},
      {"--resolution 0x8", good, {"--resolution", "0x8"}, "--resolution"},
      {"--resolution 99999x8", good, {"--resolution", "99999x8"}, "--resolution"},
      {"--resolution nanxnan", good, {"--resolution", "nanxnan"}, "--resolution"},
      {"--time 1e30", good, {"--time", "1e30"}, "--time"},
      {"--ev inf", good, {"--ev", "inf"}, "--ev"},
  };
  for (const CliCase& c : cases) {
    SCOPED_TRACE(c.name);
    test::TempDir scenes, out;
    const fs::path scene = scenes.write("extreme.json", c.sceneText);
    std::vector<std::string> argv = {cli(), "render", scene.string(), "-o", (out / "out.exr").string()};
    argv.insert(argv.end(), c.flags.begin(), c.flags.end());
    const auto r = test::runProcess(argv, 60.0);
    EXPECT_FALSE(r.timedOut);
    EXPECT_EQ(r.exitCode, test::kBadInput) << "-1 is a signal (an abort): " << r.err;
    EXPECT_TRUE(test::contains(r.err, c.mustName));
    EXPECT_FALSE(fs::exists(out / "out.exr"));
  }
}

TEST(ExtremeValuesCli, ExtremeButValidScenesRenderFiniteImages) {
  // Through the whole program (embedded coordinator, worker, EXR): radiance 1e30 gives 1e30 times
  // the image of radiance 1; f/0.5, B = 1024 and a focus at 1e308 render finite images.
  struct Good {
    std::string name, sceneText;
    std::vector<std::string> flags;
  };
  const std::vector<Good> cases = {
      {"radiance 1", withValue("lights[0].radiance", "1"), {}},
      {"radiance 1e30", withValue("lights[0].radiance", "1e30"), {}},
      {"f/0.5", withValue("camera.f_number", "0.5"), {}},
      {"focus at 1e308", withValue("camera.focus_distance", "1e308"), {}},
      {"B = 1024", withValue("camera.f_number", "2"), {"--max-bounces", "1024"}},
  };
  std::vector<double> means;
  for (const Good& c : cases) {
    SCOPED_TRACE(c.name);
    test::TempDir scenes, out;
    const fs::path scene = scenes.write("extreme.json", c.sceneText);
    std::vector<std::string> argv = {cli(), "render", scene.string(), "-o", (out / "out.exr").string(), "-q"};
    argv.insert(argv.end(), c.flags.begin(), c.flags.end());
    const auto r = test::runProcess(argv, 120.0);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Image image = readExr(out / "out.exr");
    double mean = 0.0;
    for (float v : image.rgb) {
      ASSERT_TRUE(std::isfinite(v));
      ASSERT_GE(v, 0.0f);
      mean += v / double(image.rgb.size());
    }
    EXPECT_GT(mean, 0.0);
    means.push_back(mean);
  }
  EXPECT_NEAR(means[1] / means[0] / 1e30, 1.0, 1e-5);
}

}  // namespace
}  // namespace lensfarm
