// The durable coordinator: what it acknowledged survives a crash, and a restarted coordinator
// finishes the job with the same bits as one that never stopped, also when the crash or a bad
// disk damaged its state dir.
#include <gtest/gtest.h>

#include <functional>

#include <filesystem>
#include <fstream>
#include <map>

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

// ---- a state dir damaged by a crash or a bad disk (state_store.h) ----
// Each case ends with the exact image (the damaged units rendered again, what the database lost
// taken back from the files) and a line saying what was repaired, never with a silently different
// image, a job gone or a file deleted: a "crash" taken as a copy of the state dir, then damaged
// byte by byte as a bad disk would.

void flipBytes(const fs::path& file, size_t offset, size_t count) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  for (size_t k = 0; k < count; ++k) {
    f.seekg(std::streamoff(offset + k));
    const int c = f.get();
    f.seekp(std::streamoff(offset + k));
    f.put(char(c ^ 0x5A));
  }
}

class DamagedState : public ::testing::Test {
 protected:
  // Two jobs, each with units 0 and 1 in the checkpoint (sensor.bin) and units 2 and 3 in unit
  // files and the ledger; units 4 and 5 not rendered. Then the "crash": a copy of the state dir.
  void SetUp() override {
    options_.stateDir = dir_ / "live";
    options_.checkpointEverySeconds = 3600;  // only the explicit checkpoint below
    auto first = std::make_unique<Coordinator>(options_);
    jobs_ = {first->submit(sixUnits(), 0).id, first->submit(sixUnits(), 0).id};
    WorkerInfo info = workerInfo("a");
    info.kernels = {"sse2", "avx2"};  // the jobs pin avx2 (docs/farm.md "Mixed machines")
    const std::string a = first->registerWorker(info);
    std::map<std::pair<std::string, uint64_t>, LeaseGrant> grants;
    while (auto g = first->lease(a, 0)) grants.emplace(std::pair(g->jobId, g->unit.index), *g);
    ASSERT_EQ(grants.size(), 12u);
    for (const uint64_t from : {0, 2}) {
      for (const std::string& job : jobs_)
        for (uint64_t unit = from; unit < from + 2; ++unit)
          ASSERT_TRUE(first->acceptResult(resultFor(a, grants.at({job, unit}))));
      if (from == 0) {
        ASSERT_GT(first->checkpoint(), 0u);
      }
    }
    fs::copy(options_.stateDir, dir_ / "crashed", fs::copy_options::recursive);
    first.reset();
    options_.stateDir = dir_ / "crashed";
    for (const std::string& job : jobs_) {
      ASSERT_TRUE(fs::exists(jobDir(job) / "sensor.bin"));
      ASSERT_TRUE(fs::exists(jobDir(job) / "unit-3.bin"));
      ASSERT_FALSE(fs::exists(jobDir(job) / "unit-1.bin")) << "folded into the checkpoint";
    }
  }

  fs::path jobDir(const std::string& job) const { return options_.stateDir / "jobs" / job; }

  // Restarts on the damaged copy and renders what is left; checks each job's image against one
  // that never stopped, and returns the units leased again per job.
  std::map<std::string, std::vector<uint64_t>> finish(Coordinator& c) {
    std::map<std::string, std::vector<uint64_t>> leased;
    const std::string b = c.registerWorker(workerInfo("b"));
    while (auto g = c.lease(b, 0)) {
      leased[g->jobId].push_back(g->unit.index);
      c.acceptResult(resultFor(b, *g));
    }
    for (const std::string& job : jobs_) {
      EXPECT_EQ(c.job(job).state, JobState::kDone) << job;
      EXPECT_EQ(c.image(job).image.rgb, kExact) << job << ": the image must not change a single bit";
    }
    return leased;
  }

  static std::string events(const Coordinator& c, const std::string& job) {
    std::string out;
    for (const auto& e : c.job(job).events) out += e.text + "\n";
    return out;
  }

  const std::vector<float> kExact = uninterrupted().rgb;
  test::TempDir dir_;
  Coordinator::Options options_;
  std::vector<std::string> jobs_;
};

// An archived image is checked against the SHA-256 kept beside it before it is read or streamed:
// a damaged one is one error naming the file, never another image.
TEST(DamagedArchive, AnArchivedImageWithFlippedBytesIsOneErrorNamingTheFile) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.archiveAfterSeconds = -1;
  Coordinator c(options);
  const std::string job = c.submit(sixUnits(), 0).id;
  const std::string a = c.registerWorker(workerInfo("a"));
  while (auto g = c.lease(a, 0)) ASSERT_TRUE(c.acceptResult(resultFor(a, *g)));
  c.archiveJob(job);
  uint64_t size = 0;
  ASSERT_NE(c.archivedExr(job, &size), nullptr);
  EXPECT_EQ(c.image(job).image.rgb, uninterrupted().rgb);
  const fs::path file = dir / "state" / "jobs" / job / "final.exr";
  ASSERT_EQ(size, fs::file_size(file));
  flipBytes(file, size_t(size) - 40, 4);
  for (const auto& call :
       std::vector<std::function<void()>>{[&] { c.image(job); }, [&] { c.archivedExr(job, &size); }}) {
    try {
      call();
      ADD_FAILURE() << "a damaged archive was served";
    } catch (const FarmError& e) {
      EXPECT_EQ(e.kind(), FarmError::Kind::kFailedPrecondition);
      const std::string what = e.what();
      EXPECT_NE(what.find("(jobs/" + job + "/final.exr in the state dir) is damaged: checksum mismatch"),
                std::string::npos)
          << what;
      EXPECT_EQ(what.find(dir.path().string()), std::string::npos) << "the state dir's path stays private: " << what;
    }
  }
}

TEST_F(DamagedState, ABitFlippedUnitFileIsRenderedAgainAndKeptAside) {
  flipBytes(jobDir(jobs_[0]) / "unit-3.bin", 100, 64);
  Coordinator c(options_);
  EXPECT_EQ(c.job(jobs_[0]).unitsDone, 3u) << "units 0, 1 (checkpoint) and 2";
  EXPECT_NE(events(c, jobs_[0]).find("unit 3 of " + jobs_[0] + ": file damaged (checksum mismatch)"), std::string::npos)
      << events(c, jobs_[0]);
  EXPECT_TRUE(fs::exists(options_.stateDir / "lost+found" / (jobs_[0] + "-unit-3.bin"))) << "kept, not deleted";
  const auto leased = finish(c);
  EXPECT_EQ(leased.at(jobs_[0]), (std::vector<uint64_t>{3, 4, 5}));
  EXPECT_EQ(leased.at(jobs_[1]), (std::vector<uint64_t>{4, 5})) << "the other job loses nothing";
}

TEST_F(DamagedState, ATruncatedUnitFileStopsOnlyThatUnit) {
  const fs::path unit = jobDir(jobs_[1]) / "unit-2.bin";
  fs::resize_file(unit, fs::file_size(unit) / 2);
  Coordinator c(options_);
  EXPECT_NE(events(c, jobs_[1]).find("unit 2 of " + jobs_[1] + ": file damaged (truncated"), std::string::npos)
      << events(c, jobs_[1]);
  const auto leased = finish(c);
  EXPECT_EQ(leased.at(jobs_[1]), (std::vector<uint64_t>{2, 4, 5}));
  EXPECT_EQ(leased.at(jobs_[0]), (std::vector<uint64_t>{4, 5}));
}

TEST_F(DamagedState, ADamagedCheckpointFallsBackToTheLedgerAndItsUnitsAreRenderedAgain) {
  flipBytes(jobDir(jobs_[0]) / "sensor.bin", 40, 64);
  Coordinator c(options_);
  EXPECT_NE(events(c, jobs_[0]).find("sensor.bin is damaged (checksum mismatch)"), std::string::npos)
      << events(c, jobs_[0]);
  EXPECT_TRUE(fs::exists(options_.stateDir / "lost+found" / (jobs_[0] + "-sensor.bin")));
  const auto leased = finish(c);
  EXPECT_EQ(leased.at(jobs_[0]), (std::vector<uint64_t>{0, 1, 4, 5})) << "its units 2 and 3 are kept";
}

// SQLite loses its state: the database emptied with its WAL, the WAL alone lost (the database
// file holds only what was checkpointed into it), or its header overwritten. The jobs come back
// from their files: job.json, the checkpoint and the unit files.
TEST_F(DamagedState, AnEmptiedDatabaseLosesNoJob) {
  for (const char* f : {"state.db-wal", "state.db-shm"}) fs::remove(options_.stateDir / f);
  fs::resize_file(options_.stateDir / "state.db", 0);
  Coordinator c(options_);
  for (const std::string& job : jobs_) {
    EXPECT_EQ(c.job(job).unitsDone, 4u) << job;
    EXPECT_NE(events(c, job).find("taken back"), std::string::npos) << events(c, job);
    EXPECT_EQ(c.job(job).kernel, "avx2") << "the pinned kernel comes back from job.json: " << job;
  }
  const auto leased = finish(c);
  EXPECT_EQ(leased.at(jobs_[0]), (std::vector<uint64_t>{4, 5}));
  EXPECT_EQ(c.submit(sixUnits(), 0).id, "job-3") << "ids are not reissued";
}

TEST_F(DamagedState, ARestartKeepsEachJobsPinnedKernel) {
  Coordinator c(options_);
  for (const std::string& job : jobs_) EXPECT_EQ(c.job(job).kernel, "avx2") << job;
  finish(c);
}

TEST_F(DamagedState, ALostWalLosesNoUnit) {
  fs::resize_file(options_.stateDir / "state.db-wal", 0);
  Coordinator c(options_);
  for (const std::string& job : jobs_) EXPECT_EQ(c.job(job).unitsDone, 4u) << job;
  const auto leased = finish(c);
  EXPECT_EQ(leased.at(jobs_[1]), (std::vector<uint64_t>{4, 5}));
}

TEST_F(DamagedState, ADatabaseWithFlippedBytesIsKeptAsideAndItsJobsComeBack) {
  for (const char* f : {"state.db-wal", "state.db-shm"}) fs::remove(options_.stateDir / f);
  flipBytes(options_.stateDir / "state.db", 0, 64);  // its header: "not a database"
  Coordinator c(options_);
  bool keptAside = false;
  for (const auto& entry : fs::directory_iterator(options_.stateDir / "lost+found"))
    keptAside |= entry.path().filename().string().rfind("state.db", 0) == 0;
  EXPECT_TRUE(keptAside) << "the damaged database is kept, not deleted";
  for (const std::string& job : jobs_) EXPECT_EQ(c.job(job).unitsDone, 4u) << job;
  finish(c);
}

// A directory the database cannot explain (no row, no valid job.json) is kept aside, never
// deleted; a deletion a crash cut short is finished.
TEST_F(DamagedState, NothingTheDatabaseCannotExplainIsDeleted) {
  fs::create_directories(options_.stateDir / "jobs" / "job-77");
  std::ofstream(options_.stateDir / "jobs" / "job-77" / "unit-0.bin") << "someone's data";
  fs::rename(jobDir(jobs_[1]), options_.stateDir / "jobs" / (".deleting-" + jobs_[1]));
  Coordinator c(options_);
  EXPECT_TRUE(fs::exists(options_.stateDir / "lost+found" / "job-77" / "unit-0.bin"));
  EXPECT_THROW(c.job(jobs_[1]), FarmError) << "the deletion the crash cut short is finished";
  EXPECT_FALSE(fs::exists(options_.stateDir / "jobs" / (".deleting-" + jobs_[1])));
  EXPECT_EQ(c.job(jobs_[0]).unitsDone, 4u);
}

}  // namespace
}  // namespace lensfarm
