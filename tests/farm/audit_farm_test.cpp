// The cross-worker audit over real gRPC between real processes, end to end: a real
// coordinator, five honest worker processes, and one worker whose every upload is its rendered
// sums times 1.001 (a broken machine or a wrong build: its results are plausible, only wrong).
// With the default audit fraction it is caught by the audit of its first unit, quarantined, and
// the image is the in-process render's, bit for bit; `lensfarm workers` and the job's events say
// what happened.
#include <gtest/gtest.h>

#include <thread>

#include "proto/channel_security.h"
#include "tests/farm/farm_fixture.h"
#include "worker/grpc_link.h"
#include "worker/worker_loop.h"

namespace lensfarm {
namespace {

// A link whose worker is wrong: the sums it uploads are `scale` times those it rendered.
class ScalingLink final : public CoordinatorLink {
 public:
  ScalingLink(CoordinatorLink& inner, double scale) : inner_(inner), scale_(scale) {}
  Registration registerWorker(const WorkerInfo& info) override { return inner_.registerWorker(info); }
  std::vector<uint64_t> heartbeat(const std::string& id, const std::vector<uint64_t>& leases) override {
    return inner_.heartbeat(id, leases);
  }
  std::optional<LeaseGrant> lease(const std::string& id, double wait) override { return inner_.lease(id, wait); }
  JobSpec jobSpec(const std::string& jobId) override { return inner_.jobSpec(jobId); }
  std::string asset(const std::string& sha256) override { return inner_.asset(sha256); }
  bool upload(const UnitResult& result) override {
    UnitResult wrong = result;
    for (double& s : wrong.buffer.sums) s *= scale_;
    return inner_.upload(wrong);
  }
  void reportFailure(const std::string& id, uint64_t lease, const std::string& job, const std::string& e) override {
    inner_.reportFailure(id, lease, job, e);
  }
  void leave() override { inner_.leave(); }

 private:
  CoordinatorLink& inner_;
  const double scale_;
};

class AuditFarm : public test::FarmFixture {};

TEST_F(AuditFarm, AWrongWorkerAmongSixIsQuarantinedAndTheImageKeepsItsBits) {
  const std::filesystem::path scene = writeScene(24, 36, 1);  // 36 units of one sample
  const std::string address = startCoordinator();             // the default audit fraction, 2 %
  GrpcCoordinatorLink grpc(makeChannel(address, ChannelSecurity{}, 0.3, true), ChannelSecurity{});
  ScalingLink wrongLink(grpc, 1.001);
  WorkerOptions options;
  options.name = "wrong";
  options.leaseWaitSeconds = 0.5;
  options.maxBackoffSeconds = 0.3;
  WorkerLoop wrong(wrongLink, options);
  std::thread wrongThread([&] { wrong.run(); });
  for (int i = 1; i <= 5; ++i) startWorker(address, "honest-" + std::to_string(i));
  // All six registered before the job, so that every worker's first unit has others to audit it.
  ASSERT_TRUE(test::waitFor(
      [&] {
        const auto listed = cli({"workers", "--coordinator", address});
        size_t n = 0;
        for (size_t at = listed.out.find("honest-"); at != std::string::npos; at = listed.out.find("honest-", at + 1))
          ++n;
        return n == 5 && listed.out.find("wrong") != std::string::npos;
      },
      60));

  const std::string job = submit(address, scene);
  const auto watched = cli({"watch", job, "--coordinator", address});
  wrong.stopNow();
  wrongThread.join();
  ASSERT_EQ(watched.exitCode, 0) << watched.err;

  expectFarmImageIsTheLocalRender(address, job, scene, "a wrong worker must not change a single bit");

  const auto workers = cli({"workers", "--coordinator", address});
  ASSERT_EQ(workers.exitCode, 0) << workers.err;
  const size_t line = workers.out.find("wrong");
  ASSERT_NE(line, std::string::npos) << workers.out;
  const std::string wrongLine = workers.out.substr(line, workers.out.find('\n', line) - line);
  EXPECT_NE(wrongLine.find("quarantined"), std::string::npos) << workers.out;
  EXPECT_EQ(workers.out.find("quarantined"), workers.out.rfind("quarantined"))
      << "only the wrong worker is quarantined:\n"
      << workers.out;

  const auto status = cli({"status", job, "--coordinator", address});
  ASSERT_EQ(status.exitCode, 0) << status.err;
  EXPECT_NE(status.out.find("is wrong"), std::string::npos) << status.out;
  EXPECT_NE(status.out.find("differ by up to 1.0e-03"), std::string::npos) << status.out;
}

}  // namespace
}  // namespace lensfarm
