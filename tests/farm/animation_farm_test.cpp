// What the farm promises for animations (docs/farm.md "Tiles and passes", "Failures"): a 24-frame
// job on a farm of real processes over gRPC with a state dir survives a worker's SIGKILL and the
// coordinator's SIGKILL and restart on the same state dir and port. Every frame downloaded
// afterwards is `lensfarm render --frames`'s, bit for bit; none is lost; and the ledger counts
// each unit once (units done = units total, each frame's tiles done = its tiles).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "common/film/image_io.h"
#include "common/scene/frame_range.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "tests/deploy_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

constexpr int kFirstFrame = 1, kLastFrame = 24, kSize = 64;
constexpr uint64_t kSpp = 32;  // long enough that the kills land mid-job on a fast machine

// GetJob over gRPC; nullopt while the coordinator does not answer (e.g. restarting).
std::optional<v1::JobStatus> getJob(const std::string& address, const std::string& job) {
  auto stub = v1::ClientService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::GetJobRequest request;
  request.set_job_id(job);
  v1::JobStatus status;
  if (!stub->GetJob(&context, request, &status).ok()) return std::nullopt;
  return status;
}

int framesComplete(const v1::JobStatus& s) {
  int n = 0;
  for (const v1::FrameStatus& f : s.frames()) n += f.complete();
  return n;
}

// The units of an image's provenance ("w1: 3 units, w2: 5 units" -> 8).
uint64_t unitsNamed(const std::string& workers) {
  uint64_t n = 0;
  const std::regex count(R"(: ([0-9]+) units)");
  for (auto it = std::sregex_iterator(workers.begin(), workers.end(), count); it != std::sregex_iterator(); ++it)
    n += std::stoull((*it)[1]);
  return n;
}

class AnimationFarm : public ::testing::Test {
 protected:
  // The animated Cornell box, small; `extra` chooses the layout (e.g. --tile-size 16).
  void renderThroughFailures(const std::vector<std::string>& layout) {
    const fs::path scene = dir_.write("scene.json", test::bundledSceneJson("cornell-animated.json").dump(2));
    std::vector<std::string> overrides = {
        "--resolution", std::to_string(kSize) + "x" + std::to_string(kSize),           "--spp", std::to_string(kSpp),
        "--frames",     std::to_string(kFirstFrame) + "-" + std::to_string(kLastFrame)};
    overrides.insert(overrides.end(), layout.begin(), layout.end());

    // The clean run: one process.
    std::vector<std::string> render = {
        "render", scene.string(), "-o", (dir_ / "ref_####.exr").string(), "--threads", "2", "-q"};
    render.insert(render.end(), overrides.begin(), overrides.end());
    const auto reference = farm_.cli(render);
    ASSERT_EQ(reference.exitCode, 0) << reference.err;

    // The farm: a state dir, two workers.
    const fs::path state = dir_ / "state";
    const std::vector<std::string> coordinatorArgs = {"--heartbeat-interval", "0.2",         "--lease-timeout", "30",
                                                      "--state-dir",          state.string()};
    std::vector<std::string> first = {"--listen", "127.0.0.1:0"};
    first.insert(first.end(), coordinatorArgs.begin(), coordinatorArgs.end());
    const std::string address = farm_.startCoordinator(first);
    test::ChildProcess& doomed = farm_.startWorker("doomed", {"--coordinator", address, "--threads", "1"});
    test::ChildProcess& survivor = farm_.startWorker("w2", {"--coordinator", address, "--threads", "1"});
    std::vector<std::string> submit = {scene.string(), "--coordinator", address};
    submit.insert(submit.end(), overrides.begin(), overrides.end());
    const std::string job = farm_.submit(submit);

    // Some frames complete, not all: then the worker dies, and the coordinator after it.
    std::optional<v1::JobStatus> status;
    ASSERT_TRUE(test::waitFor([&] { return (status = getJob(address, job)) && framesComplete(*status) >= 2; }, 120))
        << farm_.coordinator().log();
    ASSERT_LT(framesComplete(*status), kLastFrame - kFirstFrame + 1)
        << "the job ended before the kills: make it longer";
    const int completeBeforeKills = framesComplete(*status);
    doomed.signal(SIGKILL);
    EXPECT_EQ(doomed.wait(10), -1);
    farm_.coordinator().signal(SIGKILL);
    EXPECT_EQ(farm_.coordinator().wait(10), -1);

    // The same state dir and port; workers again.
    std::vector<std::string> again = {"--listen", address};
    again.insert(again.end(), coordinatorArgs.begin(), coordinatorArgs.end());
    ASSERT_EQ(farm_.startCoordinator(again), address);
    const auto restarted = getJob(address, job);
    ASSERT_TRUE(restarted) << farm_.coordinator().log();
    EXPECT_GE(framesComplete(*restarted), completeBeforeKills) << "a frame complete before the kill is kept";
    test::ChildProcess& w3 = farm_.startWorker("w3", {"--coordinator", address, "--threads", "1"});
    test::ChildProcess& w4 = farm_.startWorker("w4", {"--coordinator", address, "--threads", "1"});
    const auto watched = farm_.cli({"watch", job, "--coordinator", address});
    ASSERT_EQ(watched.exitCode, 0) << watched.err << farm_.coordinator().log() << "\nw2:\n"
                                   << survivor.log() << "\nw3:\n"
                                   << w3.log() << "\nw4:\n"
                                   << w4.log();

    // The ledger: every unit once.
    const auto done = getJob(address, job);
    ASSERT_TRUE(done);
    EXPECT_EQ(done->progress().units_done(), done->progress().units_total());
    ASSERT_EQ(done->frames_size(), kLastFrame - kFirstFrame + 1);
    for (const v1::FrameStatus& f : done->frames()) {
      EXPECT_TRUE(f.complete()) << "frame " << f.frame();
      EXPECT_EQ(f.tiles_done(), f.tiles_total()) << "frame " << f.frame();
    }

    // Every frame, bit for bit. Each frame's metadata names the units each worker contributed to
    // the job ("w2: 7 units, ..."): never more than the job has, and all of them at the end — a
    // unit counted twice (say, once before the restart and again after) would push the sum over.
    uint64_t mostUnitsNamed = 0;
    const auto downloaded =
        farm_.cli({"download", job, "-o", (dir_ / "farm_####.exr").string(), "--coordinator", address});
    ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;
    for (int frame = kFirstFrame; frame <= kLastFrame; ++frame) {
      SCOPED_TRACE("frame " + std::to_string(frame));
      const fs::path farmFile = framePath((dir_ / "farm_####.exr").string(), frame);
      const fs::path refFile = framePath((dir_ / "ref_####.exr").string(), frame);
      ASSERT_TRUE(fs::exists(farmFile)) << "lost";
      ASSERT_TRUE(fs::exists(refFile));
      ImageMetadata farmMeta, refMeta;
      const Image farmImage = readExr(farmFile, &farmMeta);
      const Image refImage = readExr(refFile, &refMeta);
      EXPECT_EQ(farmMeta.totalSamples, uint64_t(kSize) * kSize * kSpp) << "each sample once";
      EXPECT_EQ(farmImage.width, kSize);
      EXPECT_TRUE(farmImage.rgb == refImage.rgb) << "differs from the clean run";
      const uint64_t named = unitsNamed(farmMeta.extra["workers"]);
      EXPECT_LE(named, done->progress().units_total()) << farmMeta.extra["workers"];
      mostUnitsNamed = std::max(mostUnitsNamed, named);
    }
    EXPECT_EQ(mostUnitsNamed, done->progress().units_total());
    std::printf("%s: %d of %d frames complete at the kills, %llu units\n", job.c_str(), completeBeforeKills,
                kLastFrame - kFirstFrame + 1, (unsigned long long)done->progress().units_total());
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
};

TEST_F(AnimationFarm, WholeFramesSurviveAWorkerKillAndACoordinatorKillAndRestart) { renderThroughFailures({}); }

TEST_F(AnimationFarm, TiledFramesSurviveAWorkerKillAndACoordinatorKillAndRestart) {
  renderThroughFailures({"--tile-size", "16"});
}

}  // namespace
}  // namespace lensfarm
