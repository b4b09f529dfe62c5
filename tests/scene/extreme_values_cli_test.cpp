// Extreme values (docs/numerics.md) through the real program: extreme scenes and flags are refused
// with exit code 2 naming the field or flag and never abort, extreme but valid scenes render finite
// images (a radiance of 1e30 gives 1e30 times the image of radiance 1), and a 1024-bounce path with
// light sampling passes the farm's counters check. Runs the real `lensfarm` binary.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/film/image_io.h"
#include "tests/scene/extreme_values_cases.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::Case;
using test::kFloatMax;
using test::Outcome;
using test::sceneText;

std::string cli() { return test::cliPath().string(); }

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
      {"an aperture of 5e24",
       withValue("camera.focal_length", "1e25",
                 {{"camera", {{"sensor_width", 1e24}, {"focus_distance", 1e30}, {"f_number", 1}}}}),
       {},
       "camera.f_number"},
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
