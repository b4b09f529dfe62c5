// Storage that does not grow forever (docs/farm.md "Assets"), on the plain Coordinator with a
// state dir: an asset no job refers to is collected once the grace has passed (archived jobs
// still refer to theirs; a deleted job does not), its file goes, a restart does not bring it back,
// and a job that refers to a collected asset is refused naming it; the per-owner quotas of asset
// bytes and of pixel-samples still to render; prefetch (which workers may fetch a job's assets
// without a lease).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::kindOf;
using test::workerInfo;

// An asset of `size` bytes, different for each `seed`; its hash.
std::string putAsset(Coordinator& c, char seed, size_t size = 1000) {
  const std::string bytes(size, seed);
  const std::string sha = sha256Hex(bytes);
  c.putAsset(sha, bytes);
  return sha;
}

// The minimal scene, listing `assets` (name -> hash) besides (a job may carry files it does not read).
JobSpec specWith(std::map<std::string, std::string> assets, uint64_t spp = 2) {
  JobSpec spec = test::minimalSpec(spp);
  spec.assets = std::move(assets);
  return spec;
}

Coordinator::Options gcOptions(const fs::path& stateDir, double grace) {
  Coordinator::Options o;
  o.auditFraction = 0.0;
  o.stateDir = stateDir;
  o.assetGraceSeconds = grace;
  return o;
}

void waitPast(double seconds) { std::this_thread::sleep_for(std::chrono::duration<double>(seconds * 1.2)); }

TEST(AssetGc, WhatNoJobRefersToGoesAfterTheGraceAndAnArchivedJobKeepsItsAssets) {
  test::TempDir dir;
  const double grace = 0.3;
  std::string shared, own, orphan, job1, job2;
  {
    Coordinator c(gcOptions(dir.path(), grace));
    shared = putAsset(c, 'a');
    own = putAsset(c, 'b');
    orphan = putAsset(c, 'c');
    job1 = c.submit(specWith({{"shared.bin", shared}, {"own.bin", own}}), 0, "ann").id;
    job2 = c.submit(specWith({{"shared.bin", shared}}), 0, "ann").id;
    EXPECT_EQ(c.collectAssets(), 0u) << "within the grace nothing goes, not even the orphan";
    // job1 is cancelled mid-way and archived: it still refers to its assets.
    c.cancel(job1);
    c.archiveJob(job1);
    EXPECT_TRUE(c.job(job1).archived);
    // (the coordinator's own check runs every grace / 4; collectAssets() is the same pass)
    waitPast(grace);
    c.collectAssets();
    EXPECT_FALSE(c.hasAsset(orphan)) << "uploaded, never submitted, past the grace: collected";
    EXPECT_FALSE(fs::exists(dir.path() / "assets" / orphan)) << "its file too";
    EXPECT_TRUE(c.hasAsset(own)) << "the archived job refers to it";
    EXPECT_TRUE(c.hasAsset(shared));
    // Deleting job1: its own asset is unreferenced from now on, the shared one is job2's still.
    c.deleteJob(job1);
    c.collectAssets();
    EXPECT_TRUE(c.hasAsset(own)) << "the grace starts when the last job lets go";
    waitPast(grace);
    c.collectAssets();
    EXPECT_FALSE(c.hasAsset(own));
    EXPECT_TRUE(c.hasAsset(shared));
    // A job that refers to a collected asset is refused, naming it, and nothing is submitted.
    const size_t before = c.jobs().size();
    EXPECT_EQ(kindOf([&] { c.submit(specWith({{"own.bin", own}}), 0, "ann"); }), FarmError::Kind::kFailedPrecondition);
    EXPECT_EQ(c.jobs().size(), before);
    EXPECT_EQ(c.metricsSnapshot().assetsCollected, 2u);
  }
  // A restart keeps what was kept and does not bring back what went; uploading again works.
  Coordinator c(gcOptions(dir.path(), grace));
  EXPECT_TRUE(c.hasAsset(shared));
  EXPECT_FALSE(c.hasAsset(own));
  EXPECT_FALSE(c.hasAsset(orphan));
  EXPECT_EQ(putAsset(c, 'b'), own);
  EXPECT_TRUE(c.hasAsset(own));
  EXPECT_NO_THROW(c.submit(specWith({{"own.bin", own}}), 0, "ann"));
  // "never": nothing is collected.
  Coordinator::Options keepAll = gcOptions(dir.path() / "other", -1.0);
  Coordinator never(keepAll);
  putAsset(never, 'z');
  waitPast(0.1);
  EXPECT_EQ(never.collectAssets(), 0u);
}

TEST(OwnerQuotas, AssetBytesCountEachAssetOnceAndRefuseOnlyTheOwnerPastThem) {
  Coordinator::Options o;
  o.auditFraction = 0.0;
  o.maxAssetBytesPerOwner = 2500;
  Coordinator c(o);
  const std::string a = putAsset(c, 'a'), b = putAsset(c, 'b'), d = putAsset(c, 'd');
  c.submit(specWith({{"a.bin", a}}), 0, "ann");
  c.submit(specWith({{"a.bin", a}, {"b.bin", b}}), 0, "ann");  // 2000 bytes: a counts once
  try {
    c.submit(specWith({{"d.bin", d}}), 0, "ann");
    FAIL() << "3000 bytes of assets for ann";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("owner ann"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--max-asset-bytes-per-owner"), std::string::npos) << e.what();
  }
  EXPECT_EQ(c.jobs().size(), 2u) << "nothing submitted";
  EXPECT_NO_THROW(c.submit(specWith({{"d.bin", d}}), 0, "bob")) << "another owner has room of their own";
}

TEST(OwnerQuotas, PixelSamplesStillToRenderFreeUpAsJobsProgress) {
  Coordinator::Options o;
  o.auditFraction = 0.0;
  o.maxSamplesPerOwner = 4 * 3 * 10;  // the minimal spec is 4 x 3 pixels: ten samples a pixel in all
  Coordinator c(o);
  const std::string first = c.submit(test::minimalSpec(6), 0, "ann").id;  // 72 pixel-samples to render
  EXPECT_EQ(kindOf([&] { c.submit(test::minimalSpec(6), 0, "ann"); }), FarmError::Kind::kResourceExhausted);
  EXPECT_NO_THROW(c.submit(test::minimalSpec(4), 0, "ann")) << "72 + 48 > 120? no: 120 is allowed";
  EXPECT_EQ(kindOf([&] { c.submit(test::minimalSpec(1), 0, "ann"); }), FarmError::Kind::kResourceExhausted);
  c.cancel(first);  // an ended job renders nothing more
  EXPECT_NO_THROW(c.submit(test::minimalSpec(6), 0, "ann"));
}

TEST(Prefetch, EligibleWorkersAreToldOnceAndMayFetchTheAssetsWithoutALease) {
  Coordinator::Options o;
  o.auditFraction = 0.0;
  Coordinator c(o);
  const std::string sha = putAsset(c, 'p');
  JobPolicy bigmem;
  bigmem.requireTags = {"bigmem"};
  const std::string job = c.submit(specWith({{"p.bin", sha}}), 0, "ann", bigmem, /*paused=*/true).id;
  WorkerInfo big = workerInfo("big");
  big.tags = {"bigmem"};
  const std::string w = c.registerWorker(big), small = c.registerWorker(workerInfo("small"));
  EXPECT_EQ(kindOf([&] { c.assetFor(w, sha); }), FarmError::Kind::kFailedPrecondition) << "no lease, no prefetch";
  EXPECT_EQ(c.takePrefetch(w), "");
  EXPECT_TRUE(c.prefetchJob(job).prefetch);
  // A worker waiting for work is answered at once, with no unit (the job is paused).
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(c.lease(w, 5.0));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(4));
  EXPECT_EQ(c.takePrefetch(w), job);
  EXPECT_EQ(c.takePrefetch(w), "") << "once";
  EXPECT_EQ(c.jobSpecFor(w, job).assets.at("p.bin"), sha);
  EXPECT_EQ(*c.assetFor(w, sha), std::string(1000, 'p'));
  EXPECT_EQ(c.takePrefetch(small), "") << "a worker without the job's tags is not asked";
  EXPECT_EQ(kindOf([&] { c.assetFor(small, sha); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(c.job(job).unitsDone, 0u);
  c.cancel(job);
  EXPECT_EQ(kindOf([&] { c.prefetchJob(job); }), FarmError::Kind::kFailedPrecondition);
  EXPECT_EQ(kindOf([&] { c.prefetchJob("job-99"); }), FarmError::Kind::kNotFound);
}

}  // namespace
}  // namespace lensfarm
