// End to end: a real coordinator and real worker processes on loopback (free ports), driven
// through the real `lensfarm` CLI. The farm's image must equal the in-process render's pixel for
// pixel, whatever the number of workers or when they join.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <fstream>
#include <regex>

#include "common/film/image_io.h"
#include "common/util/hash.h"
#include "tests/farm/farm_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class Farm : public test::FarmFixture {};

TEST_F(Farm, TwoWorkersMatchTheInProcessRenderPixelForPixel) {
  const fs::path scene = writeScene(48, 16, 2);  // 8 units
  const std::string address = startCoordinator();
  startWorker(address, "w1");
  startWorker(address, "w2");
  const std::string job = submit(address, scene);
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err << coordinator_->log();
  EXPECT_NE(watched.err.find("done"), std::string::npos) << "plain progress lines when not on a terminal";

  ImageMetadata farmMeta, localMeta;
  const Image farm = download(address, job, &farmMeta);
  const Image local = renderInProcess(scene, &localMeta);
  EXPECT_EQ(farmMeta.samplesPerPixel, 16u);
  EXPECT_EQ(localMeta.samplesPerPixel, 16u);
  EXPECT_EQ(farmMeta.sceneHash, localMeta.sceneHash);
  EXPECT_NE(farmMeta.extra["effects"].find("specular reflection: on (rippled mirror"), std::string::npos)
      << "the EXR header lists the effects simulated: " << farmMeta.extra["effects"];
  ASSERT_EQ(farm.rgb.size(), local.rgb.size());
  EXPECT_EQ(farm.rgb, local.rgb) << "the farm's image must equal the in-process render bit for bit";
  double sum = 0;
  for (float v : farm.rgb) sum += v;
  EXPECT_GT(sum, 0.0);

  // Assets reached the workers by hash, into caches that started empty.
  const std::string objSha = sha256Hex(test::readFile(scene.parent_path() / "meshes/cornell-box.obj"));
  const std::string provenance = farmMeta.extra["workers"];
  int contributors = 0;
  for (const std::string name : {"w1", "w2"}) {
    if (provenance.find(name + ":") == std::string::npos) continue;
    ++contributors;
    EXPECT_TRUE(fs::exists(dir_ / ("cache-" + name) / objSha)) << name << " rendered without the mesh?";
  }
  EXPECT_GE(contributors, 1) << provenance;

  // A preview: box-filtered to fit 20 px (48 -> 16), exposed like the download.
  const fs::path preview = dir_ / "preview.png";
  const auto snap = cli({"snapshot", job, "-o", preview.string(), "--max-size", "20", "--coordinator", address});
  EXPECT_EQ(snap.exitCode, 0) << snap.err;
  EXPECT_NE(snap.out.find("16x16, 16 spp, done"), std::string::npos) << snap.out;
  EXPECT_EQ(test::readFile(preview).substr(1, 3), "PNG");

  const auto workers = cli({"workers", "--coordinator", address});
  EXPECT_EQ(workers.exitCode, 0);
  EXPECT_NE(workers.out.find("w1"), std::string::npos);
  EXPECT_NE(workers.out.find("w2"), std::string::npos);
}

TEST_F(Farm, AWorkerJoiningMidJobChangesNothingButTheSpeed) {
  const fs::path scene = writeScene(96, 384, 8);  // 48 units of ~74k paths
  const std::string address = startCoordinator();
  startWorker(address, "early");
  const std::string job = submit(address, scene);
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, job) >= 1; }, 60));
  startWorker(address, "late");
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  ImageMetadata farmMeta, localMeta;
  const Image farm = download(address, job, &farmMeta);
  EXPECT_NE(farmMeta.extra["workers"].find("late:"), std::string::npos)
      << "the late worker should have taken units: " << farmMeta.extra["workers"];
  const Image local = renderInProcess(scene, &localMeta);
  EXPECT_EQ(farm.rgb, local.rgb);
}

TEST_F(Farm, CancelStopsTheJobAndKeepsWhatWasAccumulated) {
  const fs::path scene = writeScene(32, 1000000, 4);
  const std::string address = startCoordinator();
  startWorker(address, "w");
  const std::string job = submit(address, scene, {"--priority", "3"});
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, job) >= 2; }, 60));
  const auto cancelled = cli({"cancel", job, "--coordinator", address});
  EXPECT_EQ(cancelled.exitCode, 0) << cancelled.err;
  EXPECT_NE(cancelled.out.find("cancelled"), std::string::npos);
  const auto watched = cli({"watch", job, "--coordinator", address});
  EXPECT_EQ(watched.exitCode, 5) << "watch exits non-zero for a cancelled job";
  ImageMetadata meta;
  const Image image = download(address, job, &meta);
  EXPECT_GE(meta.samplesPerPixel, 8u);
  EXPECT_LT(meta.samplesPerPixel, 1000000u);
  EXPECT_EQ(meta.samplesPerPixel % 4, 0u) << "whole units only";
  const uint64_t frozen = unitsDone(address, job);
  // No more units are handed out: the count stays put while the worker keeps asking.
  EXPECT_FALSE(test::waitFor([&] { return unitsDone(address, job) != frozen; }, 1.0));
  const auto status = cli({"status", job, "--coordinator", address});
  EXPECT_NE(status.out.find("priority:   3"), std::string::npos) << status.out;
}

TEST_F(Farm, WorkersComeBackAfterTheCoordinatorRestarts) {
  const fs::path scene = writeScene(32, 8, 2);
  const std::string address = startCoordinator();
  test::ChildProcess& worker = startWorker(address, "w");
  ASSERT_TRUE(test::waitFor(
      [&] {
        return cli({"workers", "--coordinator", address}).out.find(" w ") != std::string::npos;
      },
      30));
  coordinator_->signal(SIGTERM);
  EXPECT_EQ(coordinator_->wait(30), 0) << "the coordinator shuts down cleanly on SIGTERM";
  EXPECT_EQ(cli({"status", "--coordinator", address}).exitCode, 3) << "unreachable coordinator: exit 3";
  ASSERT_EQ(startCoordinator(address), address);
  const std::string job = submit(address, scene);
  const auto watched = cli({"watch", job, "--coordinator", address});
  EXPECT_EQ(watched.exitCode, 0) << watched.err << worker.log();
  worker.signal(SIGTERM);
  EXPECT_EQ(worker.wait(30), 0) << worker.log();
}

TEST_F(Farm, OneWorkerAndThreeWorkersGiveTheSameBits) {
  fs::path scene = writeScene(40, 24, 2);  // 12 units
  {
    // With light tracing (render/light_tracer.h): its splats are summed in a fixed order per unit.
    // And a light tree (render/light_tree.h): each worker builds it from the scene alone.
    nlohmann::json j = nlohmann::json::parse(test::readFile(scene));
    j["render"]["light_tracing"] = "on";
    j["render"]["light_tree"] = "on";
    scene = dir_.write("scene.json", j.dump(2));
  }
  std::vector<std::vector<float>> images;
  for (int workers : {1, 3}) {
    const std::string address = startCoordinator();
    for (int w = 0; w < workers; ++w) startWorker(address, "n" + std::to_string(workers) + "-" + std::to_string(w));
    const std::string job = submit(address, scene);
    ASSERT_EQ(cli({"watch", job, "--coordinator", address}).exitCode, 0);
    ImageMetadata meta;
    images.push_back(download(address, job, &meta).rgb);
    EXPECT_EQ(meta.totalSamples, 40u * 40u * 24u) << "every unit counted once";
    workers_.clear();
  }
  EXPECT_EQ(images[0], images[1]);
}

// Path guiding (render/path_guiding.h; forced on: auto leaves it off): every worker trains the
// same field from the scene alone, so a guided job on three workers is the bits of one process,
// and differs from the unguided job.
TEST_F(Farm, AGuidedJobOnThreeWorkersIsTheBitsOfOneProcess) {
  const fs::path plain = writeScene(40, 24, 2);  // 12 units
  nlohmann::json j = nlohmann::json::parse(test::readFile(plain));
  j["render"]["path_guiding"] = "on";
  const fs::path scene = dir_.write("guided.json", j.dump(2));
  const std::string address = startCoordinator();
  for (int w = 0; w < 3; ++w) startWorker(address, "g" + std::to_string(w));
  const std::string job = submit(address, scene);
  ASSERT_EQ(cli({"watch", job, "--coordinator", address}).exitCode, 0);
  ImageMetadata farmMeta, localMeta, plainMeta;
  const Image farm = download(address, job, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 40u * 40u * 24u) << "every unit counted once";
  EXPECT_EQ(farm.rgb, renderInProcess(scene, &localMeta).rgb);
  EXPECT_NE(farm.rgb, renderInProcess(plain, &plainMeta).rgb) << "guiding changed nothing";
}

TEST_F(Farm, AWorkerKilledMidUnitCostsTimeNotCorrectness) {
  const fs::path scene = writeScene(96, 192, 8);  // 24 units of ~74k paths
  const std::string address = startCoordinator("127.0.0.1:0", {"--lease-timeout", "1"});
  test::ChildProcess& doomed = startWorker(address, "doomed");
  const std::string job = submit(address, scene);
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, job) >= 2; }, 60));
  doomed.signal(SIGKILL);  // most likely in the middle of a unit: its lease lapses after 1 s
  EXPECT_EQ(doomed.wait(30), -1);
  startWorker(address, "survivor");
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  ImageMetadata farmMeta, localMeta;
  const Image farm = download(address, job, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 96u * 96u * 192u) << "every unit counted exactly once";
  EXPECT_EQ(farm.rgb, renderInProcess(scene, &localMeta).rgb);
}

TEST_F(Farm, ACoordinatorKilledMidJobResumesFromItsStateDir) {
  const fs::path scene = writeScene(96, 256, 8);  // 32 units
  const std::string state = (dir_ / "state").string();
  const std::string address = startCoordinator("127.0.0.1:0", {"--state-dir", state, "--checkpoint-every", "0.3"});
  startWorker(address, "w1");
  startWorker(address, "w2");
  const std::string job = submit(address, scene);
  ASSERT_TRUE(test::waitFor([&] { return unitsDone(address, job) >= 6; }, 60));
  coordinator_->signal(SIGKILL);
  EXPECT_EQ(coordinator_->wait(30), -1);
  ASSERT_EQ(startCoordinator(address, {"--state-dir", state, "--checkpoint-every", "0.3"}), address);
  EXPECT_GE(unitsDone(address, job), 6u) << "acknowledged units survive the crash";
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err << coordinator_->log();
  ImageMetadata farmMeta, localMeta;
  const Image farm = download(address, job, &farmMeta);
  EXPECT_EQ(farmMeta.totalSamples, 96u * 96u * 256u) << "every unit counted exactly once";
  EXPECT_EQ(farm.rgb, renderInProcess(scene, &localMeta).rgb);
}

TEST_F(Farm, BadRequestsGetClearErrorsAndExitCodes) {
  const std::string address = startCoordinator();
  // The coordinator's address may come from the environment instead of --coordinator.
  ::setenv("LENSFARM_COORDINATOR", address.c_str(), 1);
  const auto missing = cli({"status", "job-999"});
  ::unsetenv("LENSFARM_COORDINATOR");
  EXPECT_EQ(missing.exitCode, 4) << missing.err;
  EXPECT_NE(missing.err.find("job-999"), std::string::npos);
  json bad = test::minimalSceneJson();  // a lens focused inside its focal length
  bad["camera"]["type"] = "thin_lens";
  bad["camera"]["f_number"] = 8;
  bad["camera"]["focus_distance"] = 0.01;
  const fs::path badScene = dir_.write("bad.json", bad.dump());
  const auto refused = cli({"submit", badScene.string(), "--coordinator", address});
  EXPECT_EQ(refused.exitCode, 2);
  EXPECT_NE(refused.err.find("camera.focus_distance"), std::string::npos) << refused.err;
  EXPECT_EQ(cli({"status", "--coordinator", address}).out.find("job-"), std::string::npos) << "nothing was queued";
}

TEST_F(Farm, ATargetErrorJobStopsAtTheSameUnitOnTheFarmAsInOneProcess) {
  // The stop is the first prefix of units whose estimate reaches the target, decided in unit
  // order: two workers finishing units in any order keep exactly the units one process keeps.
  const fs::path scene = writeScene(24, 64, 0);
  const std::vector<std::string> rule = {"--target-error", "0.08", "--spp", "4096"};
  const std::string address = startCoordinator();
  startWorker(address, "w1");
  startWorker(address, "w2");
  const std::string job = submit(address, scene, rule);
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  EXPECT_NE(watched.out.find("target error reached"), std::string::npos) << watched.out;
  const auto status = cli({"status", job, "--coordinator", address});
  EXPECT_NE(status.out.find("stopped:    target error reached"), std::string::npos) << status.out;
  EXPECT_NE(status.out.find("(target 8.00 % reached)"), std::string::npos) << status.out;
  ImageMetadata farmMeta, localMeta;
  const Image farm = download(address, job, &farmMeta);
  EXPECT_LT(farmMeta.samplesPerPixel, 4096u) << "stopped before the cap";

  const fs::path local = dir_ / "local.exr";
  std::vector<std::string> args = {"render", scene.string(), "-o", local.string(), "-q"};
  args.insert(args.end(), rule.begin(), rule.end());
  const auto r = cli(args);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("stopped:           target error reached"), std::string::npos) << r.out;
  EXPECT_EQ(readExr(local, &localMeta).rgb, farm.rgb);
  EXPECT_EQ(localMeta.samplesPerPixel, farmMeta.samplesPerPixel);
}

}  // namespace
}  // namespace lensfarm
