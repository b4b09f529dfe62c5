// The job life cycle (coordinator/core/lifecycle.cpp, docs/farm.md "Job life cycle"): deleting,
// archiving, the retention policy and list filters, on a plain Coordinator (no network), with
// results of known sums so that accumulation needs no rendering.
#include <gtest/gtest.h>
#include <malloc.h>

#include <filesystem>
#include <thread>

#include "common/util/error.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::workerInfo;

// A job of `units` units of one sample on a width x height frame, its scene named `name`.
JobSpec smallJob(int width = 4, int height = 3, int units = 3, const std::string& name = "small.json") {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = units;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {width, height};
  return JobSpec{name, scene.dump(), {}, {}, std::nullopt};
}

// Renders every unit of the coordinator's queue through worker `w`; unit k sums to 1 + k / 7 (a
// film whose image is not constant across units, so a wrong image would show).
void renderAll(Coordinator& c, const std::string& w, int width = 4, int height = 3) {
  while (auto g = c.lease(w, 0)) {
    UnitResult r = test::resultFor(w, *g, 1.0 + double(g->unit.index) / 7.0, 0.0, width, height);
    for (size_t k = 0; k < r.buffer.sums.size(); ++k) r.buffer.sums[k] += double(k % 5) * 0.25;
    c.acceptResult(r);
  }
}

using test::kindOf;

// Bytes the C allocator holds for the program (small blocks and mmap'ed ones).
uint64_t heapBytes() {
  const struct mallinfo2 m = ::mallinfo2();
  return uint64_t(m.uordblks) + uint64_t(m.hblkhd);
}

TEST(ParseDuration, ReadsUnitsAndRefusesTheRest) {
  EXPECT_DOUBLE_EQ(parseDuration("7d", "--keep"), 7 * 86400.0);
  EXPECT_DOUBLE_EQ(parseDuration("12h", "--keep"), 12 * 3600.0);
  EXPECT_DOUBLE_EQ(parseDuration("30m", "--keep"), 1800.0);
  EXPECT_DOUBLE_EQ(parseDuration("3600s", "--keep"), 3600.0);
  EXPECT_DOUBLE_EQ(parseDuration("2w", "--keep"), 14 * 86400.0);
  EXPECT_DOUBLE_EQ(parseDuration("0.2s", "--keep"), 0.2);
  EXPECT_DOUBLE_EQ(parseDuration("90", "--keep"), 90.0);
  EXPECT_DOUBLE_EQ(parseDuration("0", "--keep"), 0.0);
  for (const char* bad : {"7x", "", "d", "1.5.2h", "7 days", "1e3"}) {
    try {
      parseDuration(bad, "--keep");
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_TRUE(test::contains(e.what(), "--keep: expected a duration such as 7d")) << bad;
    }
  }
  try {
    parseDuration("-1d", "--archive-after");
    ADD_FAILURE() << "a negative duration was accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(test::contains(e.what(), "--archive-after: a duration cannot be negative"));
  }
}

TEST(JobLifecycle, DeleteRemovesTheJobAndRefusesUploadsForIt) {
  Coordinator c;
  const std::string job = c.submit(smallJob(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const LeaseGrant first = *c.lease(w, 0), second = *c.lease(w, 0);
  ASSERT_TRUE(c.acceptResult(test::resultFor(w, first, 1.0)));

  // Running: refused unless forced, and nothing changes.
  EXPECT_EQ(kindOf([&] { c.deleteJob(job); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(c.job(job).state, JobState::kRunning);
  c.deleteJob(job, /*force=*/true);

  EXPECT_TRUE(c.jobs().empty());
  EXPECT_EQ(kindOf([&] { c.job(job); }), FarmError::Kind::kNotFound);
  EXPECT_EQ(kindOf([&] { c.deleteJob(job); }), FarmError::Kind::kNotFound) << "deleting twice";
  EXPECT_EQ(kindOf([&] { c.deleteJob("job-99"); }), FarmError::Kind::kNotFound);
  // The worker still holds a lease of the deleted job: its upload is refused, and counts nothing.
  EXPECT_EQ(kindOf([&] { c.admitUpload(w, second.leaseId, job, second.unit.index, 4, 3); }),
            FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(kindOf([&] { c.acceptResult(test::resultFor(w, second, 2.0)); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(c.metricsSnapshot().unitsDone, 1u);
  EXPECT_EQ(c.heartbeat(w, {second.leaseId}), std::vector<uint64_t>{second.leaseId}) << "told to drop it";
  EXPECT_FALSE(c.lease(w, 0).has_value()) << "nothing of the deleted job is leased";
}

TEST(JobLifecycle, ArchiveKeepsTheImageBitForBitAndFreesTheFilm) {
  constexpr int kW = 400, kH = 300;  // a sensor of at least kW * kH * 3 doubles: 2.9 MB
  Coordinator c;
  const std::string job = c.submit(smallJob(kW, kH, 3), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  EXPECT_EQ(kindOf([&] { c.archiveJob(job); }), FarmError::Kind::kFailedPrecondition) << "queued";
  renderAll(c, w, kW, kH);
  const JobInfo done = c.job(job);
  ASSERT_EQ(done.state, JobState::kDone);
  EXPECT_FALSE(done.archived);
  const JobImage before = c.image(job);
  const std::string sensor = c.sensorState(job);

  const uint64_t heldBefore = heapBytes();
  const JobInfo archived = c.archiveJob(job);
  const uint64_t heldAfter = heapBytes();
  EXPECT_TRUE(archived.archived);
  // The film is gone: at least the sensor's serialized size (its sums) was given back, though the
  // encoded EXR (about a third of it, float32) is now held.
  EXPECT_GT(heldBefore, heldAfter + sensor.size() / 2) << "before " << heldBefore << ", after " << heldAfter;
  EXPECT_EQ(kindOf([&] { c.sensorState(job); }), FarmError::Kind::kFailedPrecondition);

  const JobImage after = c.image(job);
  EXPECT_EQ(after.image.width, kW);
  EXPECT_TRUE(after.image.rgb == before.image.rgb) << "the archived image is the developed one, bit for bit";
  EXPECT_EQ(after.metadata.samplesPerPixel, before.metadata.samplesPerPixel);
  EXPECT_EQ(after.metadata.extra, before.metadata.extra);
  EXPECT_EQ(after.exposure.ev, before.exposure.ev);
  // Its status stays as it was.
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.state, JobState::kDone);
  EXPECT_EQ(info.unitsDone, done.unitsDone);
  EXPECT_EQ(info.samplesPerPixelDone, done.samplesPerPixelDone);
  EXPECT_EQ(info.stats.rays, done.stats.rays);
  EXPECT_DOUBLE_EQ(info.endedUnixSeconds, done.endedUnixSeconds);
  EXPECT_TRUE(c.archiveJob(job).archived) << "archiving again changes nothing";
  c.deleteJob(job);
  EXPECT_TRUE(c.jobs().empty());
}

TEST(JobLifecycle, ArchivedAndDeletedJobsStayThatWayAcrossARestart) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.checkpointEverySeconds = 3600;
  std::string kept, archived, deleted;
  JobImage image;
  double ended = 0.0;
  {
    Coordinator c(options);
    const std::string w = c.registerWorker(workerInfo("w"));
    kept = c.submit(smallJob(), 0, "alice").id;
    renderAll(c, w);
    archived = c.submit(smallJob(8, 6), 0, "bob").id;
    renderAll(c, w, 8, 6);
    deleted = c.submit(smallJob(), 0).id;  // the highest id: not issued again after the restart
    renderAll(c, w);
    c.checkpoint();
    ended = c.job(kept).endedUnixSeconds;
    EXPECT_GT(ended, 0.0);
    const fs::path archivedDir = options.stateDir / "jobs" / archived;
    EXPECT_TRUE(fs::exists(archivedDir / "sensor.bin"));
    image = c.image(archived);
    c.archiveJob(archived);
    EXPECT_TRUE(fs::exists(archivedDir / "final.exr"));
    EXPECT_FALSE(fs::exists(archivedDir / "sensor.bin")) << "the checkpoint of an archived job is removed";
    c.deleteJob(deleted);
    EXPECT_FALSE(fs::exists(options.stateDir / "jobs" / deleted)) << "a deleted job's files are removed";
  }
  Coordinator c(options);
  EXPECT_EQ(kindOf([&] { c.job(deleted); }), FarmError::Kind::kNotFound) << "a restart does not resurrect it";
  ASSERT_EQ(c.jobs().size(), 2u);
  EXPECT_EQ(c.job(kept).owner, "alice");
  EXPECT_DOUBLE_EQ(c.job(kept).endedUnixSeconds, ended) << "the end time is stored";
  const JobInfo a = c.job(archived);
  EXPECT_TRUE(a.archived);
  EXPECT_EQ(a.owner, "bob");
  EXPECT_EQ(a.unitsDone, 3u);
  EXPECT_EQ(a.samplesPerPixelDone, 3u);
  EXPECT_TRUE(c.image(archived).image.rgb == image.image.rgb);
  const std::string next = c.submit(smallJob(), 0).id;
  EXPECT_NE(next, deleted) << "a deleted job's id is not issued again";
}

TEST(JobLifecycle, RetentionArchivesAtOnceAndDeletesAfterKeep) {
  Coordinator::Options options;
  options.archiveAfterSeconds = 0.0;
  options.keepSeconds = 0.3;
  Coordinator c(options);
  const std::string w = c.registerWorker(workerInfo("w"));
  const std::string ended = c.submit(smallJob(), 0).id;
  renderAll(c, w);
  const std::string running = c.submit(smallJob(), 0).id;
  ASSERT_TRUE(c.lease(w, 0).has_value());
  // Archived when it ended, then deleted once it is older than --keep; the running job stays.
  EXPECT_TRUE(test::waitFor([&] { return c.jobs().size() == 1; }, 20));
  EXPECT_EQ(c.jobs().at(0).id, running);
  EXPECT_EQ(kindOf([&] { c.job(ended); }), FarmError::Kind::kNotFound);
}

TEST(JobLifecycle, RetentionAppliesAtStartUpToJobsThatEndedBefore) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  std::string job;
  {
    Coordinator c(options);
    const std::string w = c.registerWorker(workerInfo("w"));
    job = c.submit(smallJob(), 0).id;
    renderAll(c, w);
  }
  // Archived at start-up, before the constructor returns.
  options.archiveAfterSeconds = 0.0;
  {
    Coordinator c(options);
    EXPECT_TRUE(c.job(job).archived);
  }
  // Older than --keep by the time the next coordinator starts: deleted before it returns.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  options.keepSeconds = 0.2;
  Coordinator c(options);
  EXPECT_TRUE(c.jobs().empty());
  EXPECT_FALSE(fs::exists(options.stateDir / "jobs" / job));
}

TEST(JobLifecycle, ListFiltersByStateOwnerNameAndLimit) {
  Coordinator c;
  const std::string w = c.registerWorker(workerInfo("w"));
  const std::string done = c.submit(smallJob(4, 3, 3, "shot-010.json"), 0, "alice").id;
  renderAll(c, w);
  const std::string queued = c.submit(smallJob(4, 3, 3, "shot-020.json"), 0, "bob").id;
  const std::string other = c.submit(smallJob(4, 3, 3, "turntable.json"), 0, "alice").id;
  const auto ids = [&](const Coordinator::JobFilter& f) {
    std::vector<std::string> out;
    for (const JobInfo& info : c.jobs(f)) out.push_back(info.id);
    return out;
  };
  EXPECT_EQ(ids({}), (std::vector<std::string>{done, queued, other}));
  EXPECT_EQ(ids({{JobState::kDone}, "", "", 0}), std::vector<std::string>{done});
  EXPECT_EQ(ids({{JobState::kQueued, JobState::kRunning}, "", "", 0}), (std::vector<std::string>{queued, other}));
  EXPECT_EQ(ids({{}, "alice", "", 0}), (std::vector<std::string>{done, other}));
  EXPECT_EQ(ids({{}, "", "shot-", 0}), (std::vector<std::string>{done, queued}));
  EXPECT_EQ(ids({{}, "alice", "shot-", 0}), std::vector<std::string>{done});
  EXPECT_EQ(ids({{}, "", "", 2}), (std::vector<std::string>{done, queued}));
  EXPECT_EQ(c.job(queued).owner, "bob");
}

}  // namespace
}  // namespace lensfarm
