// What an operator sees of a running farm: the coordinator's Prometheus metrics scraped over HTTP
// from a real process serving real workers, its gRPC health service, and the workers' logs.
#include <gtest/gtest.h>
#include <signal.h>

#include <regex>

#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class Observability : public ::testing::Test {
 protected:
  std::map<std::string, double> metrics() {
    return test::parseMetrics(test::httpGet(farm_.metricsAddress(), "/metrics"));
  }
  double metric(const std::string& name) {
    const auto m = metrics();
    const auto it = m.find(name);
    return it == m.end() ? -1.0 : it->second;
  }
  static size_t count(const std::string& text, const std::string& pattern) {
    const std::regex re(pattern);
    return size_t(std::distance(std::sregex_iterator(text.begin(), text.end(), re), std::sregex_iterator()));
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
};

TEST_F(Observability, MetricsFollowARealJob) {
  const fs::path scene = test::writeSeedScene(dir_, 96, 768, 64);  // 12 units of 590k paths
  const std::string address = farm_.startCoordinator({"--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0",
                                                      "--heartbeat-interval", "0.2", "--lease-timeout", "3"});
  EXPECT_EQ(test::grpcHealth(address), "SERVING") << "grpc.health.v1 answers without a token";
  EXPECT_EQ(metric("lensfarm_units_done_total"), 0.0);

  test::ChildProcess& w1 = farm_.startWorker("w1", {"--coordinator", address, "--threads", "1"});
  test::ChildProcess& w2 = farm_.startWorker("w2", {"--coordinator", address, "--threads", "1"});
  ASSERT_TRUE(test::waitFor([&] { return metric("lensfarm_workers_alive") == 2.0; }, 30)) << metrics().size();
  const std::string job = farm_.submit({scene.string(), "--coordinator", address});

  // Mid-job: some units in, the job running, samples flowing (units are summed in order: two
  // counted may both wait for unit 0, so wait until some are summed too).
  ASSERT_TRUE(test::waitFor(
      [&] { return metric("lensfarm_units_done_total") >= 2.0 && metric("lensfarm_samples_per_second") > 0.0; }, 60));
  const auto mid = metrics();
  EXPECT_EQ(mid.at("lensfarm_jobs{state=\"running\"}"), 1.0);
  EXPECT_LT(mid.at("lensfarm_units_done_total"), 12.0);
  EXPECT_GT(mid.at("lensfarm_samples_per_second"), 0.0);
  EXPECT_GE(mid.at("lensfarm_received_bytes_total{kind=\"unit\"}"), 2 * 96.0 * 96 * 3 * sizeof(double));
  EXPECT_EQ(mid.at("lensfarm_received_bytes_total{kind=\"asset\"}"),
            double(fs::file_size(scene.parent_path() / "meshes/cornell-box.obj")));

  const auto watched = farm_.cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  const auto done = metrics();
  EXPECT_EQ(done.at("lensfarm_jobs{state=\"done\"}"), 1.0);
  EXPECT_EQ(done.at("lensfarm_jobs{state=\"running\"}"), 0.0);
  EXPECT_EQ(done.at("lensfarm_units_done_total"), 12.0);
  EXPECT_GT(done.at("lensfarm_units_done_total"), mid.at("lensfarm_units_done_total"));
  // Each worker's first unit (and about 2 % of the others) is rendered again by the other worker
  // and compared (docs/farm.md "Audit"): those leases, uploads and log lines come on top.
  const double audits = done.at("lensfarm_audits_total{result=\"passed\"}");
  EXPECT_GE(audits, 2.0) << "each worker's first unit is audited";
  EXPECT_EQ(done.at("lensfarm_audits_total{result=\"failed\"}"), 0.0);
  EXPECT_EQ(done.at("lensfarm_units_leased_total"), 12.0 + audits);
  EXPECT_EQ(done.at("lensfarm_units_expired_total"), 0.0);
  EXPECT_EQ(done.at("lensfarm_samples_total"), 96.0 * 96 * 768);
  EXPECT_EQ(done.at("lensfarm_received_bytes_total{kind=\"unit\"}"), (12 + audits) * 96.0 * 96 * 3 * sizeof(double));
  EXPECT_EQ(done.at("lensfarm_workers_alive"), 2.0);

  // Each worker logs one line per unit, and the lines add up to the job.
  const std::string unitLine =
      R"(\] info unit [0-9]+ of job-1: [0-9]+ samples in [0-9.]+ s, [0-9.]+ MB uploaded, accepted)";
  EXPECT_EQ(double(count(w1.log(), unitLine) + count(w2.log(), unitLine)), 12 + audits) << w1.log() << w2.log();
  EXPECT_EQ(count(w1.log(), R"(info registered as worker-)"), 1u) << w1.log();

  // A worker stopped with SIGTERM drains and exits 0; after the lease timeout it is no longer alive.
  w2.signal(SIGTERM);
  EXPECT_EQ(w2.wait(30), 0) << w2.log();
  EXPECT_NE(w2.log().find("draining"), std::string::npos) << w2.log();
  EXPECT_TRUE(test::waitFor([&] { return metric("lensfarm_workers_alive") == 1.0; }, 30));
  EXPECT_EQ(metric("lensfarm_workers_known"), 2.0);
}

TEST_F(Observability, AWorkerLogsAnOutageOnceNotEveryRetry) {
  const std::string address = farm_.startCoordinator({"--listen", "127.0.0.1:0"});
  farm_.coordinator().signal(SIGTERM);
  ASSERT_EQ(farm_.coordinator().wait(30), 0);

  // Retries every 0.1 s at most: each at debug, the outage once at warn.
  test::ChildProcess& w =
      farm_.startWorker("w", {"--coordinator", address, "--max-backoff", "0.1", "--log-level", "debug"});
  ASSERT_TRUE(test::waitFor([&] { return count(w.log(), R"(\] debug coordinator unavailable: )") >= 5; }, 30))
      << w.log();
  EXPECT_EQ(count(w.log(), R"(\] warning coordinator unavailable: .*attempt 1,)"), 1u) << w.log();
  EXPECT_EQ(count(w.log(), R"(\] warning )"), 1u) << w.log();

  ASSERT_EQ(farm_.startCoordinator({"--listen", address}), address);
  ASSERT_TRUE(test::waitFor([&] { return w.log().find("info registered as") != std::string::npos; }, 30)) << w.log();
  EXPECT_EQ(count(w.log(), R"(\] warning )"), 1u) << "still one warning for the whole outage: " << w.log();
  EXPECT_EQ(count(w.log(), R"(\] info coordinator reachable again after [0-9]+ failed attempts over [0-9.]+ s)"), 1u)
      << w.log();
}

TEST_F(Observability, AnAddressItCannotUseStopsTheCoordinator) {
  const auto malformed =
      test::runProcess({test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--metrics-listen", "9464"}, 30);
  EXPECT_EQ(malformed.exitCode, 2);
  EXPECT_NE(malformed.err.find("--metrics-listen: expected HOST:PORT"), std::string::npos) << malformed.err;
  // Ports another coordinator holds: the second one does not start (no silent port sharing), and
  // says so in one line naming the flag, as a bad flag (exit 2).
  const std::string address = farm_.startCoordinator({"--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0"});
  const auto grpcTaken = test::runProcess({test::coordinatorPath().string(), "--listen", address}, 30);
  EXPECT_EQ(grpcTaken.exitCode, 2);
  EXPECT_NE(grpcTaken.err.find("--listen " + address + ": the port"), std::string::npos) << grpcTaken.err;
  EXPECT_NE(grpcTaken.err.find("is in use"), std::string::npos) << grpcTaken.err;
  const auto taken = test::runProcess(
      {test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--metrics-listen", farm_.metricsAddress()}, 30);
  EXPECT_EQ(taken.exitCode, 2);
  EXPECT_NE(taken.err.find("--metrics-listen " + farm_.metricsAddress() + ": the port"), std::string::npos)
      << taken.err;
}

}  // namespace
}  // namespace lensfarm
