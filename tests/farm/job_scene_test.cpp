// One way for a job to enter (farm/job_scene.h): the scene a spec describes is the same, and is
// refused in the same words, wherever it is built: by the client (the real `lensfarm` binary),
// by the coordinator at submit and at restore, and by a worker.
#include "common/farm/job_scene.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "common/util/error.h"
#include "coordinator/core/coordinator.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using json = nlohmann::json;

JobSpec specOf(const json& scene) { return JobSpec{"shot.json", scene.dump(), {}, {}, std::nullopt}; }

std::string messageOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const std::exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(JobScene, TheSpecsOverridesMakeTheScene) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = 4;
  JobSpec spec = specOf(scene);
  spec.overrides.samplesPerPixel = 32;
  spec.overrides.width = 40, spec.overrides.height = 30;
  const Scene s = jobScene(spec, {});
  EXPECT_EQ(s.render.samplesPerPixel, 32u);
  EXPECT_EQ(s.render.width, 40);
  EXPECT_EQ(s.render.height, 30);
  EXPECT_EQ(s.hash, parseScene(spec.sceneJson, "shot.json").hash) << "the hash is the text's, overrides aside";
}

TEST(JobScene, ACameraThatCannotBeBuiltIsNamedWithTheScene) {
  json scene = test::minimalSceneJson();
  scene["camera"]["type"] = "thin_lens";  // a lens focused inside its focal length
  scene["camera"]["f_number"] = 8;
  scene["camera"]["focus_distance"] = 0.01;
  const std::string m = messageOf([&] { jobScene(specOf(scene), {}); });
  EXPECT_EQ(m.rfind("shot.json: camera.focus_distance", 0), 0u) << m;
}

TEST(JobScene, AnAnimationWithAnErrorTargetIsRefusedInOneWordingByClientAndCoordinator) {
  json scene = test::minimalSceneJson();
  JobSpec spec = specOf(scene);
  spec.frames = FrameRange{1, 2, 1};
  spec.overrides.targetError = 0.05;
  const std::string direct = messageOf([&] { jobScene(spec, {}); });
  const std::string sentence = "an animation renders every frame to its samples; give samples_per_pixel alone";
  ASSERT_NE(direct.find(sentence), std::string::npos) << direct;
  // The coordinator, at submit.
  Coordinator c;
  const std::string coordinator = messageOf([&] { c.submit(spec, 0); });
  EXPECT_EQ(coordinator, direct);
  // The client, before it contacts anyone.
  const test::TempDir dir;
  const auto file = dir.path() / "shot.json";
  std::ofstream(file) << scene.dump();
  const test::ProcessResult r =
      test::runProcess({test::cliPath().string(), "render", file.string(), "--frames", "1-2", "--target-error", "0.05",
                        "-o", (dir.path() / "shot_#.exr").string()});
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find(sentence), std::string::npos) << r.err;
  // Adaptive sampling, the same way.
  spec.overrides.targetError.reset();
  spec.overrides.adaptive = true;
  EXPECT_NE(messageOf([&] { jobScene(spec, {}); }).find("adaptive sampling is for stills"), std::string::npos);
}

}  // namespace
}  // namespace lensfarm
