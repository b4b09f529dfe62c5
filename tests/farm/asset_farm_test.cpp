// Assets through a real farm: a real coordinator (metrics on) and real workers, driven by the real
// `lensfarm` CLI. A scene of several assets goes over the network once: a second submit of it
// uploads nothing (FindMissingAssets), and a worker fetches each asset once however many jobs and
// units use it, and not again after a restart (its --cache-dir).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <regex>

#include "common/util/hash.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class AssetFarm : public ::testing::Test {
 protected:
  // The bundled outdoor scene, small: two meshes and a sky map, copied beside it.
  fs::path writeScene() {
    json scene = json::parse(std::ifstream(test::scenesDir() / "glass-metal-sky.json"));
    scene["render"]["resolution"] = {32, 20};
    scene["render"]["samples_per_pixel"] = 8;
    scene["render"]["samples_per_unit"] = 2;  // 4 units
    for (const char* asset : {"meshes/sphere.obj", "meshes/cube.obj", "skies/clear-sky.exr"}) {
      const std::string bytes = test::readFile(test::scenesDir() / asset);
      dir_.write(asset, bytes);
      assetBytes_ += bytes.size();
      hashes_.push_back(sha256Hex(bytes));
    }
    return dir_.write("scene.json", scene.dump(2));
  }
  double metric(const std::string& name) {
    const auto m = test::parseMetrics(test::httpGet(farm_.metricsAddress(), "/metrics"));
    const auto it = m.find(name);
    return it == m.end() ? -1.0 : it->second;
  }
  double assetBytesReceived() { return metric("lensfarm_received_bytes_total{kind=\"asset\"}"); }
  // `lensfarm submit`: its job id, its log lines on stderr.
  std::string submit(const std::vector<std::string>& args, std::string* log) {
    std::vector<std::string> argv = {"submit"};
    argv.insert(argv.end(), args.begin(), args.end());
    const test::ProcessResult r = farm_.cli(argv);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    *log = r.err;
    return r.out.substr(0, r.out.find('\n'));
  }
  void watch(const std::string& address, const std::string& job) {
    const test::ProcessResult r = farm_.cli({"watch", job, "--coordinator", address});
    EXPECT_EQ(r.exitCode, 0) << job << ": " << r.err << farm_.coordinator().log();
  }
  // The worker's "fetched asset" log lines, by hash prefix.
  static std::map<std::string, int> fetches(const std::string& log) {
    std::map<std::string, int> count;
    const std::regex line(R"(\] info fetched asset \S+ \(([0-9a-f]{12}), [0-9.]+ MB\))");
    for (auto it = std::sregex_iterator(log.begin(), log.end(), line); it != std::sregex_iterator(); ++it)
      ++count[(*it)[1]];
    return count;
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  uint64_t assetBytes_ = 0;
  std::vector<std::string> hashes_;
};

TEST_F(AssetFarm, ASceneGoesOverTheNetworkOnceAndEachWorkerFetchesItsAssetsOnce) {
  const fs::path scene = writeScene();
  const std::string address = farm_.startCoordinator({"--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0",
                                                      "--heartbeat-interval", "0.2", "--lease-timeout", "5"});
  test::ChildProcess* worker = &farm_.startWorker("w1", {"--coordinator", address, "--threads", "1"});

  std::string log;
  const std::string first = submit({scene.string(), "--coordinator", address}, &log);
  EXPECT_TRUE(test::contains(log, "assets: 3 uploaded (")) << log;
  EXPECT_TRUE(test::contains(log, "0 skipped, already on the coordinator (0.00 MB)")) << log;
  EXPECT_EQ(assetBytesReceived(), double(assetBytes_));

  // The same scene again: nothing is uploaded.
  const std::string second = submit({scene.string(), "--coordinator", address}, &log);
  EXPECT_NE(first, second);
  EXPECT_TRUE(test::contains(log, "assets: 0 uploaded (0.00 MB), 3 skipped, already on the coordinator (")) << log;
  EXPECT_EQ(assetBytesReceived(), double(assetBytes_)) << "the second submit sent no asset bytes";
  EXPECT_EQ(metric("lensfarm_asset_uploads_total{outcome=\"stored\"}"), 3.0);
  EXPECT_EQ(metric("lensfarm_asset_uploads_total{outcome=\"present\"}"), 0.0) << "and began no upload";

  // Two jobs of four units each on one worker: each asset fetched once.
  watch(address, first);
  watch(address, second);
  EXPECT_EQ(metric("lensfarm_units_done_total"), 8.0);
  EXPECT_EQ(metric("lensfarm_assets_sent_total"), 3.0);
  std::map<std::string, int> once;
  for (const std::string& sha : hashes_) once[sha.substr(0, 12)] = 1;
  EXPECT_EQ(fetches(worker->log()), once) << worker->log();

  // Restarted on its cache dir, the worker fetches nothing for a third job on the same assets.
  worker->signal(SIGTERM);
  ASSERT_EQ(worker->wait(30), 0) << worker->log();
  worker = &farm_.startWorker("w1", {"--coordinator", address, "--threads", "1"});
  const std::string third = submit({scene.string(), "--coordinator", address, "--spp", "4"}, &log);
  EXPECT_TRUE(test::contains(log, "0 uploaded (0.00 MB), 3 skipped")) << log;
  watch(address, third);
  EXPECT_TRUE(test::contains(worker->log(), "loaded scene.json for " + third)) << worker->log();
  EXPECT_TRUE(fetches(worker->log()).empty()) << worker->log();
  EXPECT_EQ(metric("lensfarm_assets_sent_total"), 3.0);
  EXPECT_EQ(assetBytesReceived(), double(assetBytes_));
  EXPECT_EQ(metric("lensfarm_asset_uploads_total{outcome=\"present\"}"), 0.0);
}

TEST_F(AssetFarm, AMalformedHashIsRefusedNamingIt) {
  // The CLI never sends one; a script talking gRPC might. The real coordinator names the index.
  const std::string address = farm_.startCoordinator({"--listen", "127.0.0.1:0"});
  auto stub = v1::ClientService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  v1::FindMissingAssetsRequest request;
  request.add_sha256(std::string(64, 'a'));
  request.add_sha256("not-a-hash");
  v1::FindMissingAssetsResponse response;
  grpc::ClientContext context;
  const grpc::Status s = stub->FindMissingAssets(&context, request, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(s.error_message(), "sha256[1]: \"not-a-hash\" is not a SHA-256 (64 lowercase hex digits)");
}

}  // namespace
}  // namespace lensfarm
