// The worker's lease loop against a real Coordinator, wired by direct calls (client/in_process_link.h,
// as `lensfarm render` wires it): the races between its heartbeat thread and its uploads.
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "coordinator/core/coordinator.h"
#include "tests/support/forwarding_link.h"
#include "tests/test_support.h"
#include "worker/worker_loop.h"

namespace lensfarm {
namespace {

// An 8x8 job of the minimal scene, `spp` samples per pixel in units of `perUnit`; its id.
std::string submitTinyJob(Coordinator& coordinator, int spp, int perUnit) {
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {8, 8};
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = perUnit;
  return coordinator.submit(JobSpec{"test.json", scene.dump(), {}, {}, std::nullopt}, 0).id;
}

// The real link, but each upload, once the coordinator has taken it (and so ended its lease),
// waits until the worker's heartbeat thread has asked about that very lease and heard it is gone:
// the interleaving that a busy machine produces now and then.
class UploadThenHeartbeatLink final : public test::ForwardingLink {
 public:
  using test::ForwardingLink::ForwardingLink;
  std::vector<uint64_t> heartbeat(const std::string& w, const std::vector<uint64_t>& leases) override {
    std::vector<uint64_t> revoked = inner_.heartbeat(w, leases);
    std::lock_guard lock(mutex_);
    for (uint64_t id : revoked)
      if (uploaded_ && id == *uploaded_) heardRevoked_ = true;
    changed_.notify_all();
    return revoked;
  }
  bool upload(const UnitResult& r) override {
    const bool accepted = inner_.upload(r);
    std::unique_lock lock(mutex_);
    uploaded_ = r.leaseId;
    heardRevoked_ = false;
    races_ += changed_.wait_for(lock, std::chrono::seconds(10), [&] { return heardRevoked_; }) ? 1 : 0;
    return accepted;
  }
  int races() {
    std::lock_guard lock(mutex_);
    return races_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<uint64_t> uploaded_;
  bool heardRevoked_ = false;
  int races_ = 0;
};

// A lease that ends because the coordinator took its upload is not a revocation: the worker says
// nothing about it and abandons nothing (`lensfarm render` used to warn "lease ... revoked by the
// coordinator; abandoning the unit" a few times a render, for units it had just delivered).
TEST(WorkerLoop, ALeaseEndedByItsOwnUploadIsNotReportedRevoked) {
  auto sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("worker-loop-test", sink));
  spdlog::set_level(spdlog::level::info);

  Coordinator::Options options;
  options.heartbeatIntervalSeconds = 0.01;
  Coordinator coordinator(options);
  const std::string job = submitTinyJob(coordinator, 4, 1);

  UploadThenHeartbeatLink link(coordinator);
  WorkerOptions wo;
  wo.name = "w";
  wo.threads = 1;
  wo.leaseWaitSeconds = 0.05;
  WorkerLoop worker(link, wo);
  std::thread t([&] { worker.run(); });
  EXPECT_TRUE(test::waitFor([&] { return isTerminal(coordinator.job(job).state); }, 60));
  worker.stop();
  t.join();
  spdlog::set_default_logger(previous);

  EXPECT_EQ(coordinator.job(job).state, JobState::kDone);
  EXPECT_EQ(link.races(), 4) << "every upload met the heartbeat that asks about its lease";
  EXPECT_EQ(worker.counters().unitsAbandoned.load(), 0u);
  EXPECT_EQ(worker.counters().unitsAccepted.load(), 4u);
  for (const std::string& line : sink->last_formatted()) EXPECT_EQ(line.find("revoked"), std::string::npos) << line;
}

// The real link, counting the worker's goodbyes.
class LeaveCountingLink final : public test::ForwardingLink {
 public:
  using test::ForwardingLink::ForwardingLink;
  void leave() override { ++leaves; }
  std::atomic<int> leaves{0};
};

// --idle-exit (deploy/slurm: a batch worker gives its allocation back): the worker renders every
// unit there is, then, with nothing to lease for the idle time, returns by itself and says goodbye.
TEST(WorkerLoop, LeavesByItselfOnceTheFarmHasHadNoWorkForTheIdleTime) {
  Coordinator coordinator{Coordinator::Options{}};
  const std::string job = submitTinyJob(coordinator, 6, 2);

  LeaveCountingLink link(coordinator);
  WorkerOptions wo;
  wo.name = "w";
  wo.leaseWaitSeconds = 0.05;
  wo.idleExitSeconds = 0.5;
  WorkerLoop worker(link, wo);
  std::atomic<bool> returned{false};
  std::thread t([&] {
    worker.run();
    returned = true;
  });
  const bool left = test::waitFor([&] { return returned.load(); }, 60);
  if (!left) worker.stopNow();
  t.join();
  ASSERT_TRUE(left) << "the worker never left an idle farm";
  EXPECT_EQ(coordinator.job(job).state, JobState::kDone) << "it left only after the work was done";
  EXPECT_EQ(worker.counters().unitsAccepted.load(), 3u);
  EXPECT_EQ(link.leaves.load(), 1) << "it said it was leaving (shown as left, not lost)";
}

}  // namespace
}  // namespace lensfarm
