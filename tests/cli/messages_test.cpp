// Messages a user can act on, through the real binaries: a misspelt field shows the misspelling
// and the name meant, a file that is not a scene is named for what it is, errors in a model name
// the model (never a scene file the user did not write), a resolution may be written 100X100,
// and a coordinator that cannot be reached, or is not a coordinator, is said in a sentence with
// the documented exit code (2: the address is malformed; 3: nothing or the wrong server answers).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "common/util/error.h"
#include "tests/support/gltf_builder.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::contains;

test::ProcessResult lensfarm(std::vector<std::string> args, double timeoutSeconds = 60.0) {
  args.insert(args.begin(), test::cliPath().string());
  return test::runProcess(args, timeoutSeconds);
}

std::string loadError(const test::TempDir& dir, const json& scene) {
  try {
    (void)test::loadSceneJson(dir, scene);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(Messages, AMisspeltFieldShowsTheMisspellingAndTheNameMeant) {
  const test::TempDir dir;
  json lens = test::minimalSceneJson();
  lens["camera"].erase("focal_length");
  lens["camera"]["focal_lenght"] = 0.1;
  EXPECT_TRUE(contains(loadError(dir, lens),
                       "camera.focal_length: give exactly one of focal_length and angle_of_view; the object has "
                       "\"focal_lenght\": a misspelling of \"focal_length\"?"));
  json spp = test::minimalSceneJson();
  spp["render"]["samples_per_pixle"] = 4;
  EXPECT_TRUE(
      contains(loadError(dir, spp), "render.samples_per_pixle: unknown field; did you mean \"samples_per_pixel\"?"));
  json albedo = test::minimalSceneJson();
  albedo["materials"]["white"] = {{"type", "lambertian"}, {"Albedo", 0.5}};
  EXPECT_TRUE(contains(loadError(dir, albedo), "\"Albedo\""));
  // Far from every name: the list of names, no guess.
  json far = test::minimalSceneJson();
  far["render"]["colour_science"] = true;
  const std::string e = loadError(dir, far);
  EXPECT_TRUE(contains(e, "render.colour_science: unknown field (expected one of"));
  EXPECT_EQ(e.find("did you mean"), std::string::npos) << e;
}

TEST(Messages, AFileThatIsNotASceneIsNamedForWhatItIs) {
  const test::TempDir dir;
  const std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16);
  const fs::path scene = dir.write("picture.json", png);
  const auto r = lensfarm({"render", scene.string(), "-o", (dir / "out.png").string()});
  EXPECT_EQ(r.exitCode, test::kBadInput);
  EXPECT_TRUE(contains(r.err, "picture.json: is a PNG image, not a scene"));
  for (const char c : r.err) EXPECT_TRUE(c == '\n' || (c >= 32 && c < 127)) << "a raw byte in: " << r.err;
  const fs::path exr = dir.write("frame.json", std::string("\x76\x2f\x31\x01\x02\0\0\0", 8));
  EXPECT_TRUE(contains(lensfarm({"render", exr.string()}).err, "is an OpenEXR image, not a scene"));
}

TEST(Messages, ErrorsInAModelNameTheModel) {
  // An orthographic camera chosen from a model: refused, naming the model file as given.
  const test::TempDir dir;
  test::Builder b;
  b.doc["cameras"] = {{{"type", "orthographic"},
                       {"name", "flat"},
                       {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"znear", 0.1}, {"zfar", 10}}}}};
  b.doc["nodes"] = {{{"camera", 0}}};
  const fs::path model = dir.write("Cameras.gltf", b.embedded());
  const auto r = lensfarm({"render", model.string(), "-o", (dir / "out.png").string()});
  EXPECT_EQ(r.exitCode, test::kBadInput);
  EXPECT_TRUE(contains(r.err, model.string() + ": ")) << r.err;
  EXPECT_EQ(r.err.find(".scene.json"), std::string::npos) << r.err;
}

TEST(Messages, AResolutionMayBeWrittenWithACapitalX) {
  const test::TempDir dir;
  const fs::path scene = dir.write("s.json", test::minimalSceneJson().dump());
  const auto r = lensfarm({"render", scene.string(), "-o", (dir / "out.exr").string(), "--resolution", "20X10", "-q"});
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out.exr"));
}

// A coordinator with a dashboard on free ports.
struct Farm {
  test::TempDir dir;
  std::unique_ptr<test::ChildProcess> coordinator;
  std::string address, dashboard;
  Farm() {
    coordinator = std::make_unique<test::ChildProcess>(
        std::vector<std::string>{test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--port-file",
                                 (dir / "port").string(), "--dashboard-listen", "127.0.0.1:0", "--dashboard-port-file",
                                 (dir / "dashboard").string()},
        dir / "coordinator");
    EXPECT_TRUE(
        test::waitFor([&] { return !test::readFile(dir / "dashboard").empty() || !coordinator->running(); }, 30));
    address = firstLine(test::readFile(dir / "port"));
    dashboard = firstLine(test::readFile(dir / "dashboard"));
  }
  static std::string firstLine(std::string s) { return s.substr(0, s.find('\n')); }
};

TEST(Messages, CoordinatorAddressMistakesAreSentences) {
  Farm farm;
  ASSERT_FALSE(farm.address.empty() || farm.dashboard.empty()) << farm.coordinator->log();
  // A URL scheme in front: malformed (2), with the address to give instead.
  const auto scheme = lensfarm({"status", "--coordinator", "http://" + farm.address});
  EXPECT_EQ(scheme.exitCode, test::kBadInput) << scheme.err;
  EXPECT_TRUE(contains(scheme.err, "give HOST:PORT without \"http://\""));
  EXPECT_TRUE(contains(scheme.err, "--coordinator " + farm.address));
  // The dashboard's port given as the coordinator's: an HTTP server, not a coordinator (3).
  const auto http = lensfarm({"status", "--coordinator", farm.dashboard});
  EXPECT_EQ(http.exitCode, 3) << http.err;
  EXPECT_TRUE(contains(http.err, "an HTTP server answered, not a lensfarm coordinator")) << http.err;
  // Nothing listening (3).
  const auto nothing = lensfarm({"status", "--coordinator", "127.0.0.1:" + std::to_string(test::freePort())});
  EXPECT_EQ(nothing.exitCode, 3) << nothing.err;
  EXPECT_TRUE(contains(nothing.err, "unreachable")) << nothing.err;
  // The real address works.
  EXPECT_EQ(lensfarm({"status", "--coordinator", farm.address}).exitCode, 0);
}

TEST(Messages, APortInUseIsOneLineNamingTheFlag) {
  Farm farm;
  ASSERT_FALSE(farm.address.empty()) << farm.coordinator->log();
  const auto second = test::runProcess({test::coordinatorPath().string(), "--listen", farm.address}, 30);
  EXPECT_EQ(second.exitCode, test::kBadInput) << second.err;
  EXPECT_TRUE(contains(second.err, "--listen " + farm.address + ": the port")) << second.err;
  EXPECT_TRUE(contains(second.err, "is in use")) << second.err;
  const auto dashboard = test::runProcess(
      {test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--dashboard-listen", farm.dashboard}, 30);
  EXPECT_EQ(dashboard.exitCode, test::kBadInput) << dashboard.err;
  EXPECT_TRUE(contains(dashboard.err, "--dashboard-listen " + farm.dashboard)) << dashboard.err;
}

}  // namespace
}  // namespace lensfarm
