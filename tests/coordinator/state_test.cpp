// The durable coordinator: what it acknowledged survives a crash, and a restarted coordinator
// finishes the job with the same bits as one that never stopped.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::workerInfo;

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kValues[] = {1e16, 1.0, 3.0, 1.0, 5.0, 7.0};  // order-sensitive sums (1e16's ulp is 2)

JobSpec sixUnits() {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = 6;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {4, 3};
  return JobSpec{"six.json", scene.dump(), {}, {}, std::nullopt};
}

UnitResult resultFor(const std::string& worker, const LeaseGrant& g) {
  UnitResult r = resultForLease(worker, g);
  r.buffer = SensorBuffer(4, 3);
  std::fill(r.buffer.sums.begin(), r.buffer.sums.end(), kValues[g.unit.index]);
  r.stats.paths = 12;
  r.stats.rays = 40 + g.unit.index;
  return r;
}

Image uninterrupted() {
  Coordinator c;
  const std::string job = c.submit(sixUnits(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  while (auto g = c.lease(w, 0)) c.acceptResult(resultFor(w, *g));
  EXPECT_EQ(c.job(job).state, JobState::kDone);
  return c.image(job).image;
}

TEST(DurableCoordinator, ResumesFromCheckpointAndLedgerBitForBit) {
  test::TempDir dir;
  const fs::path live = dir / "live", crashed = dir / "crashed";
  Coordinator::Options options;
  options.stateDir = live;
  options.checkpointEverySeconds = 3600;  // only the explicit checkpoint below
  auto first = std::make_unique<Coordinator>(options);
  const std::string job = first->submit(sixUnits(), 0).id;
  const std::string a = first->registerWorker(workerInfo("a"));
  std::vector<LeaseGrant> grants;
  for (int k = 0; k < 4; ++k) grants.push_back(*first->lease(a, 0));
  ASSERT_TRUE(first->acceptResult(resultFor(a, grants[2])));  // waits for 0 and 1
  ASSERT_TRUE(first->acceptResult(resultFor(a, grants[0])));
  EXPECT_GT(first->checkpoint(), 0u);                         // sensor.bin holds unit 0
  ASSERT_TRUE(first->acceptResult(resultFor(a, grants[1])));  // units 1, 2: ledger only
  // Unit 3 was leased and never acknowledged. "Crash": take the state as it is on disk now.
  fs::copy(live, crashed, fs::copy_options::recursive);
  EXPECT_TRUE(fs::exists(crashed / "jobs" / job / "unit-1.bin")) << "an acknowledged unit is on disk";

  options.stateDir = crashed;
  Coordinator second(options);
  const JobInfo restored = second.job(job);
  EXPECT_EQ(restored.state, JobState::kRunning);
  EXPECT_EQ(restored.unitsDone, 3u);
  EXPECT_EQ(restored.samplesPerPixelDone, 3u);
  EXPECT_EQ(restored.stats.rays, 40u + 41u + 42u);
  // The lease of the first run means nothing to the second: fenced off.
  EXPECT_THROW(second.acceptResult(resultFor(a, grants[3])), FarmError);
  const std::string b = second.registerWorker(workerInfo("b"));
  std::vector<uint64_t> leased;
  while (auto g = second.lease(b, 0)) {
    EXPECT_NE(g->leaseId, grants[3].leaseId) << "lease ids never repeat across restarts";
    leased.push_back(g->unit.index);
    second.acceptResult(resultFor(b, *g));
  }
  EXPECT_EQ(leased, (std::vector<uint64_t>{3, 4, 5})) << "unacknowledged unit 3 is leased again, first";
  const JobInfo done = second.job(job);
  EXPECT_EQ(done.state, JobState::kDone);
  const JobImage image = second.image(job);
  EXPECT_EQ(image.image.rgb, uninterrupted().rgb) << "a restart must not change a single bit";
  EXPECT_EQ(image.metadata.totalSamples, 6u * 12u) << "every unit counted exactly once";
  EXPECT_NE(image.metadata.extra.at("workers").find("a: 3 units"), std::string::npos)
      << image.metadata.extra.at("workers");
  EXPECT_NE(image.metadata.extra.at("workers").find("b: 3 units"), std::string::npos);
  first.reset();
}

TEST(DurableCoordinator, AJobWithAovsResumesItsLayersBitForBit) {
  // Normal (3 sums) and depth (2) beside the beauty: 8 sums a cell, checkpointed (sensor format 2)
  // and in the ledger's unit files; the restarted coordinator's layers are the uninterrupted one's.
  JobSpec spec = sixUnits();
  AovSet aovs;
  aovs.add(Aov::kNormal);
  aovs.add(Aov::kDepth);
  spec.overrides.aovs = aovs;
  const auto result = [](const std::string& w, const LeaseGrant& g) {
    UnitResult r = resultForLease(w, g);
    r.buffer = SensorBuffer(4, 3, 8);
    for (size_t c = 0; c < r.buffer.cells(); ++c) {
      double* v = &r.buffer.sums[8 * c];
      v[0] = v[1] = v[2] = kValues[g.unit.index];
      v[3] = 0.25, v[4] = -0.5, v[5] = -0.75;         // one sample's normal
      v[6] = 2.0 + double(g.unit.index), v[7] = 1.0;  // its depth, one hit
    }
    r.stats.paths = 12;
    r.stats.rays = 40;
    return r;
  };
  const auto finish = [&](Coordinator& c, const std::string& w) {
    while (auto g = c.lease(w, 0)) c.acceptResult(result(w, *g));
  };
  Coordinator reference;
  const std::string refJob = reference.submit(spec, 0).id;
  finish(reference, reference.registerWorker(workerInfo("w")));
  const Image expected = reference.image(refJob).image;
  ASSERT_EQ(expected.layers.size(), 2u);
  EXPECT_EQ(expected.layer("")->values[0], float((2.0 + 3.0 + 4.0 + 5.0 + 6.0 + 7.0) / 6.0)) << "mean depth";

  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.checkpointEverySeconds = 3600;
  std::string job;
  {
    Coordinator first(options);
    job = first.submit(spec, 0).id;
    const std::string a = first.registerWorker(workerInfo("a"));
    for (int k = 0; k < 2; ++k) first.acceptResult(result(a, *first.lease(a, 0)));
    EXPECT_GT(first.checkpoint(), 0u);
    first.acceptResult(result(a, *first.lease(a, 0)));  // the ledger's
  }
  Coordinator second(options);
  EXPECT_EQ(second.job(job).unitsDone, 3u);
  finish(second, second.registerWorker(workerInfo("b")));
  const Image image = second.image(job).image;
  EXPECT_EQ(image.rgb, expected.rgb);
  ASSERT_EQ(image.layers.size(), 2u);
  for (size_t l = 0; l < 2; ++l) EXPECT_EQ(image.layers[l].values, expected.layers[l].values) << image.layers[l].name;
}

TEST(DurableCoordinator, KeepsAssetsStatesAndFinishedImagesAcrossRestarts) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  const std::string sha = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";  // sha256sum "hello\n"
  std::string cancelledId, doneId;
  Image doneImage;
  {
    Coordinator c(options);
    c.putAsset(sha, "hello\n");
    cancelledId = c.submit(sixUnits(), 0).id;
    const std::string w = c.registerWorker(workerInfo("w"));
    c.acceptResult(resultFor(w, *c.lease(w, 0)));
    c.cancel(cancelledId);
    doneId = c.submit(sixUnits(), 0).id;
    while (auto g = c.lease(w, 0)) c.acceptResult(resultFor(w, *g));
    doneImage = c.image(doneId).image;
  }  // a clean shutdown checkpoints everything
  EXPECT_FALSE(fs::exists(dir / "state" / "jobs" / doneId / "unit-5.bin")) << "folded units are not kept twice";
  Coordinator c(options);
  EXPECT_EQ(*c.asset(sha), "hello\n");
  EXPECT_EQ(c.job(cancelledId).state, JobState::kCancelled);
  EXPECT_EQ(c.job(cancelledId).unitsDone, 1u);
  EXPECT_EQ(c.job(doneId).state, JobState::kDone);
  EXPECT_EQ(c.image(doneId).image.rgb, doneImage.rgb);
  const std::string w = c.registerWorker(workerInfo("w"));
  EXPECT_FALSE(c.lease(w, 0)) << "nothing left to do";
  EXPECT_EQ(c.submit(sixUnits(), 0).id, "job-3") << "job ids continue where they stopped";
}

TEST(DurableCoordinator, OneCoordinatorPerStateDir) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  auto first = std::make_unique<Coordinator>(options);
  try {
    Coordinator second(options);
    FAIL() << "two coordinators on one state dir would corrupt its ledger";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("another coordinator"), std::string::npos) << e.what();
  }
  first.reset();
  EXPECT_NO_THROW(Coordinator third(options)) << "the lock goes with the coordinator";
}

TEST(DurableCoordinator, RefusesAStateDirItCannotUse) {
  test::TempDir dir;
  dir.write("file", "not a directory");
  Coordinator::Options options;
  options.stateDir = dir / "file";
  EXPECT_ANY_THROW(Coordinator c(options));
}

}  // namespace
}  // namespace lensfarm
