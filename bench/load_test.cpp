// lensfarm-load: a bounded soak test of one coordinator. A coordinator is served on loopback (in
// this process, through the real gRPC services) and N simulated workers, each with its own
// channel, lease units, heartbeat, "render" for a few milliseconds and upload 512x512 buffers
// for D seconds; some are killed mid-unit (their leases lapse) and replaced. At the end it checks
// that no unit was lost or counted twice and prints units/s, MB/s and the peak resident memory.
//
//   build/bench/lensfarm-load --workers 64 --seconds 60
//
// Exit code 0 when every invariant held, 1 otherwise.
#include <grpcpp/grpcpp.h>
#include <spdlog/spdlog.h>

#include <malloc.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/service.h"
#include "proto/channel_security.h"
#include "worker/grpc_link.h"

namespace lensfarm {
namespace {

constexpr int kSize = 512;

long residentKilobytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

JobSpec loadJob(uint64_t units) {
  nlohmann::json scene = nlohmann::json::parse(R"({
    "format": "lensfarm-scene/1",
    "camera": { "type": "pinhole", "position": [0, 0, -3], "look_at": [0, 0, 0], "sensor_width": 0.1, "focal_length": 0.1 },
    "materials": { "white": { "type": "lambertian", "albedo": 0.5 } },
    "shapes": [ { "type": "quad", "corner": [-1, -1, 0], "edge1": [0, 2, 0], "edge2": [2, 0, 0], "material": "white" } ],
    "render": { "resolution": [512, 512], "samples_per_pixel": 1, "samples_per_unit": 1 }
  })");
  scene["render"]["samples_per_pixel"] = units;
  return JobSpec{"load.json", scene.dump(), {}, {}, std::nullopt};
}

struct Totals {
  std::atomic<uint64_t> accepted{0}, duplicates{0}, refused{0}, killed{0}, bytes{0};
};

// One simulated worker: a fresh registration per life; dies now and then mid-unit.
void simulatedWorker(const std::string& address, int index, double killProbability, const std::atomic<bool>& stop,
                     Totals& totals) {
  std::mt19937 rng(uint32_t(index) * 7919u + 1u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  UnitResult result;
  result.buffer = SensorBuffer(kSize, kSize);
  std::fill(result.buffer.sums.begin(), result.buffer.sums.end(), 0.5);
  result.stats.paths = 1;  // one "path" per unit: the job's path count is then its unit count
  while (!stop) {
    GrpcCoordinatorLink link(makeChannel(address, ChannelSecurity{}), ChannelSecurity{}, 30.0);
    std::string id;
    try {
      id = link.registerWorker(WorkerInfo{"load-" + std::to_string(index), 1, kProtocolVersion, kRendererVersion})
               .workerId;
    } catch (const std::exception&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    while (!stop) {
      std::optional<LeaseGrant> grant;
      try {
        grant = link.lease(id, 0.5);
      } catch (const std::exception&) {
        break;
      }
      if (!grant) continue;
      link.heartbeat(id, {grant->leaseId});
      std::this_thread::sleep_for(std::chrono::milliseconds(5 + int(u(rng) * 20)));  // "rendering"
      if (u(rng) < killProbability) {  // killed mid-unit: no upload, no more heartbeats
        ++totals.killed;
        break;
      }
      result.workerId = id;
      result.leaseId = grant->leaseId;
      result.jobId = grant->jobId;
      result.unitIndex = grant->unit.index;
      try {
        if (link.upload(result)) {
          ++totals.accepted;
          totals.bytes += result.buffer.sums.size() * sizeof(double);
        } else {
          ++totals.duplicates;
        }
      } catch (const FarmError&) {
        ++totals.refused;  // the lease lapsed meanwhile: the unit went to someone else
      } catch (const std::exception&) {
        break;
      }
    }
  }
}

}  // namespace
}  // namespace lensfarm

int main(int argc, char** argv) {
  using namespace lensfarm;
  // Unit buffers are megabytes each: keep them out of the heap arenas (glibc would otherwise raise
  // its mmap threshold after the first frees and hold freed buffers as resident memory).
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  CLI::App app{"lensfarm-load: a bounded soak test of one coordinator with simulated workers"};
  int workers = 64;
  double seconds = 60.0, kill = 0.02, leaseTimeout = 1.0;
  app.add_option("--workers", workers, "Simulated workers")->check(CLI::Range(1, 1024))->capture_default_str();
  app.add_option("--seconds", seconds, "How long to drive them")->check(CLI::Range(0.5, 3600.0))->capture_default_str();
  app.add_option("--kill", kill, "Chance that a worker dies in the middle of a unit")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--lease-timeout", leaseTimeout, "Lease timeout of the coordinator, s")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::err);

  Coordinator::Options options;
  options.leaseTimeoutSeconds = leaseTimeout;
  Coordinator coordinator(options);
  const uint64_t units = uint64_t(1) << 30;  // more than any run can finish
  const std::string job = coordinator.submit(loadJob(units), 0).id;
  ClientServiceImpl clients(coordinator);
  WorkerServiceImpl workerService(coordinator);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&clients);
  builder.RegisterService(&workerService);
  auto server = builder.BuildAndStart();
  const std::string address = "127.0.0.1:" + std::to_string(port);

  Totals totals;
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int i = 0; i < workers; ++i) threads.emplace_back([&, i] { simulatedWorker(address, i, kill, stop, totals); });
  long peakKb = residentKilobytes();
  std::vector<long> quarterPeaks(4, 0);  // bounded memory: the later quarters do not grow
  const auto start = std::chrono::steady_clock::now();
  for (double t = 0; t < seconds; t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const long kb = residentKilobytes();
    peakKb = std::max(peakKb, kb);
    long& q = quarterPeaks[std::min(3, int(4 * t / seconds))];
    q = std::max(q, kb);
  }
  stop = true;
  for (auto& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  server->Shutdown();

  // Invariants: the units summed are exactly the units acknowledged, each once; the image holds
  // exactly their samples; nothing more.
  const JobInfo info = coordinator.job(job);
  const JobImage image = coordinator.image(job);
  const uint64_t acknowledged = totals.accepted.load();
  bool ok = true;
  const auto check = [&](bool condition, const char* what) {
    if (!condition) {
      std::printf("FAILED: %s\n", what);
      ok = false;
    }
  };
  // Every acknowledged unit was counted once: paths (1 per unit) == acknowledged units.
  check(info.stats.paths <= acknowledged, "the job counts more units than were acknowledged (a double count)");
  // Units below the prefix are all in the image; acknowledged ones above it wait for a lapsed unit.
  check(info.unitsDone <= acknowledged, "more units summed than acknowledged");
  check(image.metadata.totalSamples == info.unitsDone * uint64_t(kSize) * kSize,
        "the image's samples do not match its units");
  bool exact = true;
  for (float v : image.image.rgb) exact &= (info.unitsDone == 0 || v == 0.5f);
  check(exact, "the image is not exactly the mean of the uploads");
  std::printf("workers %d, %.1f s, lease timeout %.1f s, kill chance %.2f\n", workers, elapsed, leaseTimeout, kill);
  std::printf("acknowledged units %llu (%.1f units/s, %.1f MB/s of 512x512 buffers)\n",
              (unsigned long long)acknowledged, double(acknowledged) / elapsed,
              double(totals.bytes.load()) / elapsed / 1e6);
  std::printf(
      "summed in order %llu, waiting for an earlier unit %llu, duplicates ignored %llu, stale uploads refused %llu, "
      "workers killed %llu\n",
      (unsigned long long)info.unitsDone, (unsigned long long)(acknowledged - info.unitsDone),
      (unsigned long long)totals.duplicates.load(), (unsigned long long)totals.refused.load(),
      (unsigned long long)totals.killed.load());
  std::printf("peak resident memory %.1f MB; per quarter of the run: %.0f, %.0f, %.0f, %.0f MB\n",
              double(peakKb) / 1024.0, double(quarterPeaks[0]) / 1024.0, double(quarterPeaks[1]) / 1024.0,
              double(quarterPeaks[2]) / 1024.0, double(quarterPeaks[3]) / 1024.0);
  std::printf("%s\n", ok ? "invariants held" : "INVARIANTS BROKEN");
  return ok ? 0 : 1;
}
