// Memory (docs/farm.md, "Memory"): the coordinator refuses a job it cannot hold, with the
// estimate and its limit, before allocating anything frame-sized; an allocation that fails
// anyway fails that request only; a worker refuses a unit it cannot hold with a report.
#include <gtest/gtest.h>

#include <new>
#include <thread>

#include "common/farm/job_layout.h"
#include "common/farm/memory_estimate.h"
#include "common/util/hash.h"
#include "common/util/version.h"
#include "coordinator/core/audit.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/support/forwarding_link.h"
#include "tests/test_support.h"
#include "worker/worker_loop.h"

namespace lensfarm {
namespace {

using test::workerInfo;

using nlohmann::json;

JobSpec specAt(int w, int h, uint64_t spp = 2) {
  json scene = test::minimalSceneJson();
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = 1;
  scene["render"]["resolution"] = {w, h};
  JobSpec spec;
  spec.sceneName = "test.json";
  spec.sceneJson = scene.dump();
  return spec;
}

// Renders every unit of `job` as worker `w` with constant sums; the job must end done.
void finishJob(Coordinator& c, const std::string& job, const std::string& w) {
  while (auto g = c.lease(w, 0.0)) {
    UnitResult r = resultForLease(w, *g);
    const JobInfo info = c.job(g->jobId);
    r.buffer = SensorBuffer(info.width, info.height);
    std::fill(r.buffer.sums.begin(), r.buffer.sums.end(), 0.5);
    r.stats.paths = uint64_t(info.width) * info.height * g->unit.sampleCount;
    c.acceptResult(std::move(r));
  }
  EXPECT_EQ(c.job(job).state, JobState::kDone);
}

TEST(CoordinatorMemory, AJobOverTheBudgetIsRefusedWithItsEstimateAndOthersGoOn) {
  Coordinator::Options options;
  options.maxJobMemoryBytes = uint64_t(256) << 20;  // 268 MB
  options.maxJobMemorySource = "--max-job-memory";
  Coordinator c(options);
  const std::string before = c.submit(specAt(8, 6), 0).id;
  try {
    c.submit(specAt(16384, 16384), 0);
    FAIL() << "a 16384x16384 job must not fit in 268 MB";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    const std::string what = e.what();
    EXPECT_NE(what.find("16384x16384"), std::string::npos) << what;
    RenderSettings settings;
    settings.width = settings.height = 16384;
    settings.samplesPerPixel = 2;
    settings.samplesPerUnit = 1;
    settings.tileSize = resolveTileSize(settings, std::nullopt, 0);  // as the coordinator lays it out: tiles
    EXPECT_EQ(settings.tileSize, kTileEdge);
    const uint64_t estimate = coordinatorJobMemory(settings, options.maxBytesAhead, false, kRewindPoints).total();
    EXPECT_NE(what.find("an estimated " + formatBytes(estimate)), std::string::npos) << what;
    EXPECT_NE(what.find(" GB"), std::string::npos) << what;
    EXPECT_NE(what.find("268 MB allowed"), std::string::npos) << what;
    EXPECT_NE(what.find("--max-job-memory"), std::string::npos) << what;
  }
  EXPECT_EQ(c.jobs().size(), 1u) << "the refused job is not queued";
  // The coordinator goes on serving: the job before and one after both render to the end.
  const std::string after = c.submit(specAt(8, 6), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  finishJob(c, before, w);
  EXPECT_EQ(c.job(after).state, JobState::kDone);
  EXPECT_EQ(c.image(after).image.width, 8);
}

// The film's share of the coordinator's budget that one job of specAt(w, h) reserves.
uint64_t filmShareOf(int w, int h) {
  Coordinator c;
  c.submit(specAt(w, h), 0);
  return c.metricsSnapshot().memoryReservedBytes;
}

// Jobs are summed (--memory-budget): one that does not fit beside the others is refused with
// what holds the budget, and fits again once a job is deleted; what is reserved never passes the
// budget. (Without it, 40 queued 512x512 jobs held 794 MB against a 300 MB per-job budget.)
TEST(CoordinatorMemory, JobsTogetherStayWithinTheCoordinatorsBudget) {
  const uint64_t share = filmShareOf(512, 512);
  ASSERT_GT(share, uint64_t(512) * 512 * (kSensorBytesPerCell + kTrackerBytesPerCell));
  Coordinator::Options options;
  options.memoryBudgetBytes = 3 * share + share / 2;
  options.memoryBudgetSource = "--memory-budget";
  Coordinator c(options);
  std::vector<std::string> jobs;
  for (int k = 0; k < 3; ++k) jobs.push_back(c.submit(specAt(512, 512), 0).id);
  try {
    c.submit(specAt(512, 512), 0);
    FAIL() << "a fourth job does not fit in 3.5 jobs' budget";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    const std::string what = e.what();
    EXPECT_NE(what.find("the job needs " + formatBytes(share)), std::string::npos) << what;
    EXPECT_NE(what.find("holds " + formatBytes(3 * share) + " of its " + formatBytes(options.memoryBudgetBytes)),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("job-1 " + formatBytes(share)), std::string::npos) << what;
    EXPECT_NE(what.find("--memory-budget"), std::string::npos) << what;
  }
  EXPECT_EQ(c.jobs().size(), 3u);
  EXPECT_LE(c.metricsSnapshot().memoryReservedBytes, options.memoryBudgetBytes);
  c.cancel(jobs[0]);
  c.deleteJob(jobs[0]);
  EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, 2 * share) << "a deleted job's film is returned";
  EXPECT_NO_THROW(c.submit(specAt(512, 512), 0));
}

// Each image made for a download or snapshot reserves its bytes while it lives: one more than
// the budget holds waits, and is refused naming the budget if no room comes; room returned lets
// the next one through.
TEST(CoordinatorMemory, ImagesTakeTurnsInTheBudget) {
  const uint64_t share = filmShareOf(64, 64);
  RenderSettings s;
  s.width = s.height = 64;
  const uint64_t image = imageMemory(s);
  Coordinator::Options options;
  options.memoryBudgetBytes = share + image + image / 2;
  options.memoryBudgetSource = "--memory-budget";
  options.imageWaitSeconds = 0.2;
  Coordinator c(options);
  const std::string job = c.submit(specAt(64, 64), 0).id;
  {
    JobImage first = c.image(job);
    EXPECT_EQ(first.memory.bytes(), image);
    try {
      c.image(job);
      FAIL() << "two images do not fit";
    } catch (const FarmError& e) {
      EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
      EXPECT_NE(std::string(e.what()).find("an image of " + job + " needs " + formatBytes(image)), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("--memory-budget"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(c.image(job).image.width, 64) << "the first image's room came back";
  EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, share);
}

// Without a state dir, uploaded assets live in memory: each is reserved, and one that does not
// fit is refused, naming --state-dir.
TEST(CoordinatorMemory, AssetsInMemoryAreWithinTheBudget) {
  Coordinator::Options options;
  options.memoryBudgetBytes = 4096;
  options.memoryBudgetSource = "--memory-budget";
  Coordinator c(options);
  const std::string small(1000, 'a'), big(5000, 'b');
  EXPECT_TRUE(c.putAsset(sha256Hex(small), small));
  EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, 1000u);
  EXPECT_FALSE(c.putAsset(sha256Hex(small), small)) << "present: nothing more reserved";
  EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, 1000u);
  try {
    c.putAsset(sha256Hex(big), big);
    FAIL() << "5000 bytes do not fit in 4096";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("--state-dir"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(c.hasAsset(sha256Hex(big)));
  // An upload is admitted on its declared size, before its bytes are read: its memory while it
  // arrives is reserved, and one that could never fit is refused at once.
  {
    MemoryBudget::Reservation held = c.admitAssetUpload(sha256Hex(small), 2000);
    EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, 3000u);
  }
  EXPECT_EQ(c.metricsSnapshot().memoryReservedBytes, 1000u);
  EXPECT_EQ(test::kindOf([&] { c.admitAssetUpload(sha256Hex(big), 5000); }), FarmError::Kind::kResourceExhausted);
}

// The asset quota (--max-asset-bytes) counts every asset kept, on disk too: an upload past it is
// refused on its declared size, naming the flag; one that fits is kept.
TEST(CoordinatorMemory, AssetsStayWithinTheirQuota) {
  test::TempDir dir;
  Coordinator::Options options;
  options.stateDir = dir / "state";
  options.maxAssetBytes = 3000;
  Coordinator c(options);
  const std::string a(2000, 'a'), b(2000, 'b');
  EXPECT_TRUE(c.putAsset(sha256Hex(a), a));
  try {
    c.admitAssetUpload(sha256Hex(b), b.size());
    FAIL() << "2000 + 2000 > 3000";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("keeps 2.00 kB of assets, at most 3.00 kB (--max-asset-bytes)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(test::kindOf([&] { c.putAsset(sha256Hex(b), b); }), FarmError::Kind::kResourceExhausted);
  EXPECT_FALSE(c.hasAsset(sha256Hex(b)));
  const std::string small(900, 'c');
  EXPECT_TRUE(c.putAsset(sha256Hex(small), small));
}

// One owner's unfinished jobs are capped (--max-jobs-per-owner): past it a submit is refused,
// other owners go on, and an ended job makes room.
TEST(CoordinatorMemory, OneOwnersUnfinishedJobsAreCapped) {
  Coordinator::Options options;
  options.maxJobsPerOwner = 2;
  Coordinator c(options);
  const std::string first = c.submit(specAt(8, 6), 0, "ann").id;
  c.submit(specAt(8, 6), 0, "ann");
  try {
    c.submit(specAt(8, 6), 0, "ann");
    FAIL() << "a third unfinished job of ann's";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("owner ann has 2 jobs queued or running"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--max-jobs-per-owner"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(c.submit(specAt(8, 6), 0, "bob"));
  c.cancel(first);
  EXPECT_NO_THROW(c.submit(specAt(8, 6), 0, "ann")) << "a cancelled job no longer counts";
}

TEST(CoordinatorMemory, AFailedAllocationRefusesThatJobOnlyAndTheCoordinatorLives) {
  Coordinator::Options options;
  options.maxJobMemoryBytes = uint64_t(1) << 40;  // the estimate passes; the allocation fails
  uint64_t seen = 0;
  options.beforeJobAllocation = [&](uint64_t bytes) {
    seen = bytes;
    if (bytes > (uint64_t(1) << 30)) throw std::bad_alloc();
  };
  Coordinator c(options);
  const std::string w = c.registerWorker(workerInfo("w"));
  const std::string small = c.submit(specAt(8, 6), 0).id;
  try {
    c.submit(specAt(16384, 12000), 0);
    FAIL() << "the allocation failed: the submit must be refused";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("out of memory"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("16384x12000"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(formatBytes(seen)), std::string::npos) << e.what();
  }
  EXPECT_EQ(c.jobs().size(), 1u);
  const std::string next = c.submit(specAt(8, 6), 0).id;
  finishJob(c, small, w);
  EXPECT_EQ(c.job(next).state, JobState::kDone);
  EXPECT_EQ(next, "job-" + std::to_string(std::stoi(small.substr(4)) + 1)) << "the refused job left no trace";
}

// A worker says at registration how much one unit may take on it; the coordinator leases it only
// units that fit. A small machine in a farm never fails a big job: the job waits for a worker that
// can hold it, says so, and the small machine renders what it can meanwhile.
TEST(CoordinatorMemory, ASmallWorkerIsNeverLeasedAUnitItCannotHold) {
  Coordinator::Options options;
  options.maxJobMemoryBytes = uint64_t(1) << 40;
  Coordinator c(options);
  InProcessLink link(c);  // as `lensfarm render` wires its worker
  WorkerOptions wo;
  wo.name = "small-box";
  wo.leaseWaitSeconds = 0.05;
  wo.maxMemoryBytes = uint64_t(8) << 20;  // 8.4 MB: a 1000x1000 unit buffer is 28 MB
  WorkerLoop small(link, wo);
  std::thread t([&] { small.run(); });
  const std::string big = c.submit(specAt(1000, 1000), 0).id;
  const std::string tiny = c.submit(specAt(8, 6), 0).id;
  // The small worker renders the job it can hold, which was submitted after the big one.
  EXPECT_TRUE(test::waitFor([&] { return c.job(tiny).state == JobState::kDone; }, 30)) << c.job(tiny).error;
  ASSERT_TRUE(test::waitFor([&] { return !c.job(big).stalledReason.empty(); }, 30));
  const JobInfo waiting = c.job(big);
  EXPECT_EQ(waiting.state, JobState::kQueued) << waiting.error;
  EXPECT_NE(waiting.stalledReason.find("no connected worker can hold a unit of this job"), std::string::npos)
      << waiting.stalledReason;
  EXPECT_NE(waiting.stalledReason.find("28.0 MB"), std::string::npos) << waiting.stalledReason;
  EXPECT_NE(waiting.stalledReason.find("8.39 MB"), std::string::npos) << waiting.stalledReason;
  EXPECT_EQ(small.counters().unitsAbandoned.load(), 0u);

  // A worker that can hold it joins: the job is rendered, by it alone.
  WorkerOptions bigOptions = wo;
  bigOptions.name = "big-box";
  bigOptions.maxMemoryBytes = uint64_t(1) << 30;
  WorkerLoop bigWorker(link, bigOptions);
  std::thread u([&] { bigWorker.run(); });
  EXPECT_TRUE(test::waitFor([&] { return c.job(big).state == JobState::kDone; }, 60)) << c.job(big).error;
  EXPECT_EQ(c.job(big).stats.paths, 1000u * 1000u * 2u);
  small.stopNow();
  bigWorker.stopNow();
  t.join();
  u.join();
}

// Against a coordinator that does not know a worker's limit (an older one: the field is not
// sent), the worker itself refuses a unit it cannot hold, with a report, before allocating.
class ForgetfulLink final : public test::ForwardingLink {
 public:
  using test::ForwardingLink::ForwardingLink;
  Registration registerWorker(const WorkerInfo& info) override {
    WorkerInfo unsaid = info;
    unsaid.maxUnitMemoryBytes = 0;
    return inner_.registerWorker(unsaid);
  }
};

TEST(CoordinatorMemory, AWorkerRefusesAUnitItCannotHoldWithAReport) {
  Coordinator::Options options;
  options.maxJobMemoryBytes = uint64_t(1) << 40;
  Coordinator c(options);
  ForgetfulLink link(c);
  WorkerOptions wo;
  wo.name = "small-box";
  wo.leaseWaitSeconds = 0.05;
  wo.maxMemoryBytes = uint64_t(8) << 20;  // 8.4 MB: a 1000x1000 unit buffer is 28 MB
  WorkerLoop worker(link, wo);
  std::thread t([&] { worker.run(); });
  const std::string job = c.submit(specAt(1000, 1000), 0).id;
  EXPECT_TRUE(test::waitFor([&] { return isTerminal(c.job(job).state); }, 30));
  const JobInfo info = c.job(job);
  EXPECT_EQ(info.state, JobState::kFailed);
  EXPECT_NE(info.error.find("1000x1000"), std::string::npos) << info.error;
  EXPECT_NE(info.error.find("an estimated 28.0 MB of worker memory"), std::string::npos) << info.error;
  EXPECT_NE(info.error.find("8.39 MB allowed"), std::string::npos) << info.error;
  EXPECT_EQ(worker.counters().unitsRendered.load(), 0u) << "nothing was allocated or traced";
  // The worker lives on and renders what it can hold.
  const std::string small = c.submit(specAt(8, 6), 0).id;
  EXPECT_TRUE(test::waitFor([&] { return c.job(small).state == JobState::kDone; }, 30)) << c.job(small).error;
  worker.stopNow();
  t.join();
}

}  // namespace
}  // namespace lensfarm
