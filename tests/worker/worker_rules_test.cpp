// The worker's rules, each against a scripted coordinator (a CoordinatorLink that answers as the
// test says; the real links are tested end to end in tests/farm/): it retries an unreachable
// coordinator with growing waits, registers again when forgotten, gives up when refused, reports
// (never renders) a job it cannot render, fetches a corrupt asset again, abandons a revoked unit,
// and keeps a finished unit through an outage until it is delivered once.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <vector>

#include "common/farm/job_scene.h"
#include "common/util/error.h"
#include "common/util/hash.h"
#include "tests/test_support.h"
#include "worker/asset_cache.h"
#include "worker/worker_loop.h"

namespace lensfarm {
namespace {

using Clock = std::chrono::steady_clock;

// One job of `scene` (with `assets` by path), its units leased in order, one at a time. Every
// call is recorded; each hook, when set, answers instead of the script.
class ScriptedLink final : public CoordinatorLink {
 public:
  ScriptedLink(const nlohmann::json& scene, std::map<std::string, std::string> assets = {})
      : files_(std::move(assets)) {
    spec_ = JobSpec{"scripted.json", scene.dump(), {}, {}, std::nullopt};
    for (const auto& [path, bytes] : files_) spec_.assets[path] = sha256Hex(bytes);
    const Scene s = jobScene(spec_, [&](const std::string& p) -> std::optional<std::string> {
      auto it = files_.find(p);
      return it == files_.end() ? std::nullopt : std::optional<std::string>(it->second);
    });
    sceneHash = s.hash;
  }

  Registration registerWorker(const WorkerInfo&) override {
    std::lock_guard lock(mutex_);
    registerTimes.push_back(Clock::now());
    if (onRegister) onRegister();
    return {"w" + std::to_string(registerTimes.size()), heartbeatSeconds};
  }
  std::vector<uint64_t> heartbeat(const std::string&, const std::vector<uint64_t>& leases) override {
    std::lock_guard lock(mutex_);
    return revokeEveryLease ? leases : std::vector<uint64_t>{};
  }
  std::optional<LeaseGrant> lease(const std::string& workerId, double) override {
    std::lock_guard lock(mutex_);
    leaseCalls.push_back(workerId);
    if (onLease) onLease();
    if (unitsLeft == 0) {
      if (loop) loop->stop();
      return std::nullopt;
    }
    --unitsLeft;
    LeaseGrant g;
    g.leaseId = ++leases_;
    g.jobId = "job-1";
    g.unit = WorkUnit(leases_ - 1, (leases_ - 1) * samplesPerUnit, uint32_t(samplesPerUnit));
    g.sceneHash = grantedHash.empty() ? sceneHash : grantedHash;
    g.deadlineSeconds = 30.0;
    return g;
  }
  JobSpec jobSpec(const std::string&) override { return spec_; }
  std::string asset(const std::string& sha) override {
    std::lock_guard lock(mutex_);
    ++assetFetches;
    if (corruptFetches > 0) {
      --corruptFetches;
      return "not the bytes you are looking for";
    }
    for (const auto& [path, bytes] : files_)
      if (sha256Hex(bytes) == sha) return bytes;
    throw FarmError(FarmError::Kind::kNotFound, "no asset " + sha);
  }
  bool upload(const UnitResult& r) override {
    std::lock_guard lock(mutex_);
    ++uploadCalls;
    if (outageUploads > 0) {
      --outageUploads;
      throw LinkUnavailable("connection reset");
    }
    uploaded.push_back(r.leaseId);
    return true;
  }
  void reportFailure(const std::string&, uint64_t leaseId, const std::string&, const std::string& error) override {
    std::lock_guard lock(mutex_);
    failures.push_back({leaseId, error});
  }

  // The script.
  WorkerLoop* loop = nullptr;  // stopped when the units run out
  uint64_t unitsLeft = 1, samplesPerUnit = 1;
  double heartbeatSeconds = 1.0;
  bool revokeEveryLease = false;
  int corruptFetches = 0, outageUploads = 0;
  std::string sceneHash, grantedHash;
  std::function<void()> onRegister, onLease;  // may throw
  // What happened.
  std::vector<Clock::time_point> registerTimes;
  std::vector<std::string> leaseCalls;
  std::vector<uint64_t> uploaded;
  std::vector<std::pair<uint64_t, std::string>> failures;
  int assetFetches = 0, uploadCalls = 0;

 private:
  std::mutex mutex_;
  JobSpec spec_;
  std::map<std::string, std::string> files_;
  uint64_t leases_ = 0;
};

nlohmann::json tinyScene() {
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {8, 8};
  return scene;
}

WorkerOptions fastOptions() {
  WorkerOptions o;
  o.name = "test-worker";
  o.threads = 1;
  o.leaseWaitSeconds = 0.01;
  o.maxBackoffSeconds = 0.4;
  return o;
}

TEST(WorkerRules, AnUnreachableCoordinatorIsRetriedWithGrowingWaitsThenServed) {
  ScriptedLink link(tinyScene());
  int refusals = 4;
  link.onRegister = [&] {
    if (refusals-- > 0) throw LinkUnavailable("connection refused");
  };
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  loop.run();
  ASSERT_EQ(link.registerTimes.size(), 5u);
  EXPECT_EQ(loop.counters().registrations, 1u);
  // Waits of 0.1, 0.2, 0.4 and then the 0.4 s cap: never a busy loop, never beyond the cap's order.
  const double expected[] = {0.1, 0.2, 0.4, 0.4};
  for (size_t i = 1; i < link.registerTimes.size(); ++i) {
    const double gap = std::chrono::duration<double>(link.registerTimes[i] - link.registerTimes[i - 1]).count();
    EXPECT_GE(gap, expected[i - 1] * 0.95) << "retry " << i;
  }
  EXPECT_EQ(link.uploaded.size(), 1u) << "then the unit is rendered and delivered";
}

TEST(WorkerRules, AWorkerTheCoordinatorForgotRegistersAgain) {
  ScriptedLink link(tinyScene());
  bool forgotten = false;
  link.onLease = [&] {
    if (!forgotten) {
      forgotten = true;
      throw FarmError(FarmError::Kind::kUnknownWorker, "unknown worker w1");
    }
  };
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  loop.run();
  EXPECT_EQ(loop.counters().registrations, 2u);
  ASSERT_GE(link.leaseCalls.size(), 2u);
  EXPECT_EQ(link.leaseCalls[0], "w1");
  EXPECT_EQ(link.leaseCalls[1], "w2") << "the new identity leases";
  EXPECT_EQ(link.uploaded.size(), 1u);
}

TEST(WorkerRules, ARefusedRegistrationStopsTheWorkerWithTheCoordinatorsReason) {
  ScriptedLink link(tinyScene());
  link.onRegister = [] { throw FarmError(FarmError::Kind::kFailedPrecondition, "protocol 3, coordinator speaks 4"); };
  WorkerLoop loop(link, fastOptions());
  try {
    loop.run();
    ADD_FAILURE() << "ran on";
  } catch (const FarmError& e) {
    EXPECT_NE(std::string(e.what()).find("protocol 3"), std::string::npos) << e.what();
  }
  EXPECT_EQ(link.registerTimes.size(), 1u) << "retrying cannot help";
}

TEST(WorkerRules, AJobWhoseSceneDiffersFromItsHashIsReportedNeverRendered) {
  ScriptedLink link(tinyScene());
  link.grantedHash = "0000";
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  loop.run();
  EXPECT_TRUE(link.uploaded.empty());
  ASSERT_EQ(link.failures.size(), 1u);
  EXPECT_EQ(link.failures[0].first, 1u);
  EXPECT_NE(link.failures[0].second.find("differs from the job's 0000"), std::string::npos) << link.failures[0].second;
  EXPECT_EQ(loop.counters().unitsRendered, 0u);
}

TEST(WorkerRules, AUnitOverTheWorkersMemoryIsReportedBeforeAnythingIsAllocated) {
  ScriptedLink link(tinyScene());
  WorkerOptions options = fastOptions();
  options.maxMemoryBytes = 1024;  // less than one 8x8 unit buffer and its scene
  WorkerLoop loop(link, options);
  link.loop = &loop;
  loop.run();
  EXPECT_TRUE(link.uploaded.empty());
  ASSERT_EQ(link.failures.size(), 1u);
  EXPECT_NE(link.failures[0].second.find("1.02 kB allowed per job"), std::string::npos) << link.failures[0].second;
  EXPECT_EQ(loop.counters().unitsRendered, 0u);
}

// A transfer that arrives corrupt is never used: the worker backs off, leaves that lease to lapse
// (the coordinator leases the unit again) and fetches the asset again for its next lease.
TEST(WorkerRules, ACorruptAssetIsFetchedAgainAndTheUnitRendered) {
  nlohmann::json scene = tinyScene();
  scene["shapes"].push_back(
      {{"type", "obj"}, {"file", "ball.obj"}, {"material", "white"}, {"transform", {{"scale", 0.3}}}});
  ScriptedLink link(scene, {{"ball.obj", test::sphereObj(6, 8)}});
  link.corruptFetches = 1;
  link.unitsLeft = 2;
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  loop.run();
  EXPECT_EQ(link.assetFetches, 2);
  EXPECT_EQ(loop.assets().fetches(), 2u);
  EXPECT_EQ(link.uploaded, std::vector<uint64_t>{2}) << "the corrupt bytes rendered nothing";
  EXPECT_TRUE(link.failures.empty()) << "a transfer error is not the job's failure";
}

TEST(WorkerRules, ARevokedLeaseCancelsItsUnitAndNothingIsUploaded) {
  ScriptedLink link(tinyScene());
  link.samplesPerUnit = 1u << 18;  // a row (checked for cancellation) takes about 0.2 s here
  link.heartbeatSeconds = 0.02;
  link.revokeEveryLease = true;
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  const auto start = Clock::now();
  loop.run();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - start).count(), 120.0);
  EXPECT_EQ(loop.counters().unitsAbandoned, 1u);
  EXPECT_EQ(link.uploadCalls, 0);
}

TEST(WorkerRules, AFinishedUnitIsKeptThroughAnOutageAndDeliveredOnce) {
  ScriptedLink link(tinyScene());
  link.outageUploads = 2;
  WorkerLoop loop(link, fastOptions());
  link.loop = &loop;
  loop.run();
  EXPECT_EQ(link.uploadCalls, 3);
  EXPECT_EQ(link.uploaded, std::vector<uint64_t>{1});
  EXPECT_EQ(loop.counters().unitsAccepted, 1u);
  EXPECT_EQ(loop.counters().unitsRendered, 1u) << "rendered once, not again after the outage";
}

TEST(AssetCacheRules, ADiskCacheServesTheNextWorkerWithoutFetching) {
  test::TempDir dir;
  const std::string bytes = "v 0 0 0\n", sha = sha256Hex(bytes);
  int fetches = 0;
  const auto fetch = [&](const std::string&) {
    ++fetches;
    return bytes;
  };
  EXPECT_EQ(AssetCache(dir.path()).get(sha, fetch), bytes);
  EXPECT_EQ(AssetCache(dir.path()).get(sha, fetch), bytes);
  EXPECT_EQ(fetches, 1);
}

TEST(AssetCacheRules, BytesThatDoNotMatchTheirHashAreNeitherReturnedNorKept) {
  test::TempDir dir;
  AssetCache cache(dir.path());
  const std::string sha = sha256Hex("the real bytes");
  EXPECT_THROW(cache.get(sha, [](const std::string&) { return std::string("other bytes"); }), CorruptAsset);
  EXPECT_FALSE(std::filesystem::exists(dir / sha)) << "nothing corrupt is cached";
  EXPECT_EQ(cache.get(sha, [](const std::string&) { return std::string("the real bytes"); }), "the real bytes");
}

}  // namespace
}  // namespace lensfarm
