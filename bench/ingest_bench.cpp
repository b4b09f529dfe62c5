// Coordinator ingest: how many bytes of partial sensor buffers per second one coordinator can
// take in and sum, directly (Coordinator::acceptResult) and over gRPC from several simulated
// workers on loopback (the real WorkerService and the worker's own gRPC link). BM_UploadOverGrpc's
// argument is the upload encoding (0 raw, 1 shuffle + zstd; the coordinator accepts either); its
// synthetic sums repeat every 97 doubles and compress far better than rendered ones
// (docs/performance.md, "Upload compression").
//
//   build/bench/lensfarm-ingest-bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// An 800x800 unit is 800*800*3 doubles = 15.4 MB whatever its sample count.
#include <benchmark/benchmark.h>
#include <grpcpp/grpcpp.h>

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "common/scene/scene_loader.h"
#include "common/util/hash.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/service.h"
#include "worker/grpc_link.h"

namespace lensfarm {
namespace {

constexpr int kSize = 800;

JobSpec benchJob() {
  // cornell-seed with its box replaced by one quad: no asset to upload, the same frame size.
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(LENSFARM_SOURCE_DIR "/scenes/cornell-seed.json"));
  scene["shapes"] = nlohmann::json::array(
      {{{"type", "quad"}, {"corner", {-1, 1, 1}}, {"edge1", {2, 0, 0}}, {"edge2", {0, -2, 0}}, {"material", "white"}}});
  scene["render"]["resolution"] = {kSize, kSize};
  scene["render"]["samples_per_pixel"] = uint64_t(1) << 40;
  scene["render"]["samples_per_unit"] = 1;
  return JobSpec{"ingest.json", scene.dump(), {}, {}, std::nullopt};
}

UnitResult resultFor(const std::string& worker, const LeaseGrant& g) {
  UnitResult r = resultForLease(worker, g);
  r.buffer = SensorBuffer(kSize, kSize);
  for (size_t k = 0; k < r.buffer.sums.size(); ++k) r.buffer.sums[k] = 0.25 + double(k % 97) * 1e-3;
  r.stats.paths = uint64_t(kSize) * kSize;
  return r;
}

// Leases and accepts one 800x800 unit per iteration; only acceptResult is timed.
void acceptUnits(benchmark::State& state, Coordinator& coordinator) {
  coordinator.submit(benchJob(), 0);
  const std::string worker = coordinator.registerWorker(WorkerInfo{"bench", 1, kProtocolVersion, kRendererVersion});
  UnitResult prototype = resultFor(worker, *coordinator.lease(worker, 0));
  coordinator.acceptResult(prototype);
  for (auto _ : state) {
    state.PauseTiming();
    const auto g = coordinator.lease(worker, 0);
    UnitResult r = prototype;
    r.leaseId = g->leaseId;
    r.unitIndex = g->unit.index;
    state.ResumeTiming();
    coordinator.acceptResult(std::move(r));
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(prototype.buffer.sums.size() * sizeof(double)));
}

void BM_AcceptResultDirect(benchmark::State& state) {
  Coordinator coordinator;
  acceptUnits(state, coordinator);
}
BENCHMARK(BM_AcceptResultDirect)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same with a state dir: each unit's sums file (fsync'd) and ledger row are durable before
// acceptResult returns. The gap to BM_AcceptResultDirect is the price of "no acknowledged unit
// is ever lost".
void BM_AcceptResultDurable(benchmark::State& state) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("lensfarm-bench-" + std::to_string(::getpid()));
  {
    Coordinator::Options options;
    options.stateDir = dir;
    options.checkpointEverySeconds = 3600;
    Coordinator coordinator(options);
    acceptUnits(state, coordinator);
    // One checkpoint of the 800x800 sensor, timed on its own (it runs every --checkpoint-every s).
    const auto start = std::chrono::steady_clock::now();
    const uint64_t bytes = coordinator.checkpoint();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.counters["checkpoint_MB"] = double(bytes) / 1e6;
    state.counters["checkpoint_ms"] = seconds * 1e3;
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_AcceptResultDurable)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(40);

// The part of BM_AcceptResultDurable that a unit file's checksum costs (coordinator/store/
// checked_file.h): the SHA-256 of one 800x800 unit's sums, 15.4 MB.
void BM_UnitFileChecksum(benchmark::State& state) {
  const std::string sums(size_t(800) * 800 * 3 * sizeof(double), '\x5a');
  for (auto _ : state) benchmark::DoNotOptimize(sha256Hex(sums));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(sums.size()));
}
BENCHMARK(BM_UnitFileChecksum)->Unit(benchmark::kMillisecond)->UseRealTime();

// One coordinator served on loopback for the gRPC benchmark, shared by its threads.
struct Served {
  Coordinator coordinator;
  ClientServiceImpl clients{coordinator};
  WorkerServiceImpl workers{coordinator};
  std::unique_ptr<grpc::Server> server;
  std::string address;
  Served() {
    coordinator.submit(benchJob(), 0);
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&clients);
    builder.RegisterService(&workers);
    server = builder.BuildAndStart();
    address = "127.0.0.1:" + std::to_string(port);
  }
};

void BM_UploadOverGrpc(benchmark::State& state) {
  static std::mutex mutex;
  static std::unique_ptr<Served> served;
  {
    std::lock_guard lock(mutex);
    if (!served) served = std::make_unique<Served>();
  }
  GrpcCoordinatorLink link(makeChannel(served->address, ChannelSecurity{}), ChannelSecurity{});
  const std::string worker = link.registerWorker(WorkerInfo{"bench", 1, kProtocolVersion, kRendererVersion}).workerId;
  UnitResult result = resultFor(worker, *link.lease(worker, 1.0));
  result.uploadEncoding = SumsEncoding(state.range(0));
  link.upload(result);
  for (auto _ : state) {
    const auto g = link.lease(worker, 1.0);  // a lease per upload, as a worker does
    result.leaseId = g->leaseId;
    result.unitIndex = g->unit.index;
    link.upload(result);
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(result.buffer.sums.size() * sizeof(double)));
}
BENCHMARK(BM_UploadOverGrpc)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Arg(0)
    ->Arg(1)
    ->Threads(1)
    ->Threads(4)
    ->Threads(16);

}  // namespace
}  // namespace lensfarm

BENCHMARK_MAIN();
