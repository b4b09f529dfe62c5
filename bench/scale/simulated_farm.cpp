#include "bench/scale/simulated_farm.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "bench/scale/synthetic_image.h"
#include "common/farm/farm_types.h"
#include "common/util/version.h"
#include "proto/channel_security.h"
#include "worker/grpc_link.h"

namespace lensfarm::scale {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// makeChannel's worker channel (keepalive, short backoff) on a subchannel pool
// of its own: gRPC otherwise shares one TCP connection among every channel of a
// process with the same target and arguments, and the coordinator would see one
// client instead of a thousand.
std::shared_ptr<grpc::Channel> ownConnection(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 1000);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 5000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 5000);
  args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

constexpr int kHeartbeatPumps = 8;

void fail(FarmTally& tally, const std::string& call, const std::exception& e) {
  ++tally.failedCalls;
  ++tally.failures[call + ": " + std::string(e.what()).substr(0, 100)];
}

}  // namespace

// What a worker's thread and the heartbeat pumps share.
struct SimulatedFarm::Worker {
  explicit Worker(const FarmConfig& config, const ChannelSecurity& security)
      : link(ownConnection(config.address), security, config.callTimeoutSeconds) {}
  GrpcCoordinatorLink link;
  std::mutex mutex;
  std::string id;                 // empty: not registered (or forgotten by the coordinator)
  std::optional<uint64_t> lease;  // the lease being "rendered"
  double heartbeatInterval = 1.0;
  Clock::time_point nextHeartbeat{};
  bool registeredOnce = false;
};

double CallTimes::quantile(double q) const {
  if (seconds.empty()) return 0.0;
  std::vector<double> sorted = seconds;
  const size_t rank = std::min(sorted.size() - 1, size_t(std::ceil(q * double(sorted.size()))) - (q > 0 ? 1 : 0));
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(rank), sorted.end());
  return sorted[rank];
}

double CallTimes::max() const { return seconds.empty() ? 0.0 : *std::max_element(seconds.begin(), seconds.end()); }

void FarmTally::merge(const FarmTally& o) {
  unitsAccepted += o.unitsAccepted;
  duplicates += o.duplicates;
  refused += o.refused;
  emptyLeases += o.emptyLeases;
  failedCalls += o.failedCalls;
  for (const auto& [what, n] : o.failures) failures[what] += n;
  bytesUploaded += o.bytesUploaded;
  largestUnitCells = std::max(largestUnitCells, o.largestUnitCells);
  registerWorker.merge(o.registerWorker);
  leaseGranted.merge(o.leaseGranted);
  upload.merge(o.upload);
  heartbeat.merge(o.heartbeat);
  jobSpec.merge(o.jobSpec);
  acks.insert(acks.end(), o.acks.begin(), o.acks.end());
}

Clock::time_point FarmTally::lastAckBy(Clock::time_point t) const {
  Clock::time_point last{};
  for (const Clock::time_point a : acks)
    if (a <= t) last = std::max(last, a);
  return last;
}

SimulatedFarm::SimulatedFarm(FarmConfig config)
    : config_(std::move(config)), tallies_(size_t(config_.workers + kHeartbeatPumps)) {
  ChannelSecurity security;
  security.token = config_.workerToken;
  for (int i = 0; i < config_.workers; ++i) workers_.push_back(std::make_unique<Worker>(config_, security));
  threads_.reserve(size_t(config_.workers + kHeartbeatPumps));
  for (int i = 0; i < config_.workers; ++i) threads_.emplace_back([this, i] { run(i); });
  for (int p = 0; p < kHeartbeatPumps; ++p) threads_.emplace_back([this, p] { pumpHeartbeats(p); });
}

SimulatedFarm::~SimulatedFarm() { stop(); }

void SimulatedFarm::measureFromNow() { measureFrom_ = Clock::now().time_since_epoch().count(); }

FarmTally SimulatedFarm::stop() {
  stop_ = true;
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
  workers_.clear();  // each link drops its Attach stream
  FarmTally all;
  for (const FarmTally& t : tallies_) all.merge(t);
  return all;
}

void SimulatedFarm::record(CallTimes& times, std::chrono::steady_clock::time_point start) const {
  if (start.time_since_epoch().count() >= measureFrom_) times.add(secondsSince(start));
}

void SimulatedFarm::pumpHeartbeats(int pump) {
  FarmTally& tally = tallies_[size_t(config_.workers + pump)];
  while (!stop_) {
    Clock::time_point next = Clock::now() + std::chrono::milliseconds(50);
    for (size_t k = size_t(pump); k < workers_.size() && !stop_; k += kHeartbeatPumps) {
      Worker& w = *workers_[k];
      std::string id;
      std::vector<uint64_t> leases;
      {
        std::lock_guard lock(w.mutex);
        if (w.id.empty()) continue;
        if (Clock::now() < w.nextHeartbeat) {
          next = std::min(next, w.nextHeartbeat);
          continue;
        }
        id = w.id;
        if (w.lease) leases.push_back(*w.lease);
        w.nextHeartbeat = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(w.heartbeatInterval));
      }
      const auto t = Clock::now();
      try {
        w.link.heartbeat(id, leases);
        record(tally.heartbeat, t);
        ++heartbeats_;
      } catch (const FarmError& e) {
        fail(tally, "Heartbeat", e);
        std::lock_guard lock(w.mutex);
        if (e.kind() == FarmError::Kind::kUnknownWorker && w.id == id) w.id.clear();
      } catch (const std::exception& e) {
        fail(tally, "Heartbeat", e);
      }
    }
    std::this_thread::sleep_until(next);
  }
}

void SimulatedFarm::run(int index) {
  FarmTally& tally = tallies_[size_t(index)];
  Worker& w = *workers_[size_t(index)];
  std::mt19937 rng(uint32_t(index) * 7919u + 17u);
  std::uniform_real_distribution<double> jitter(0.5, 1.5);
  std::vector<std::string> jobsSeen;
  UnitResult result;
  // After a failed call (the coordinator unreachable or overloaded), wait as lensfarm-worker does
  // (0.1 s doubling to 2 s, jittered; its --max-backoff is 5 s) instead of retrying at once: a thousand
  // workers retrying in a loop would be a load test of the retries.
  double backoff = 0.1;
  const auto backOff = [&] {
    std::this_thread::sleep_for(std::chrono::duration<double>(backoff * jitter(rng)));
    backoff = std::min(2.0, 2 * backoff);
  };
  const auto forget = [&](const std::string& id) {  // the coordinator does not
                                                    // know us: register again
    std::lock_guard lock(w.mutex);
    if (w.id == id) w.id.clear();
  };
  while (!stop_) {
    std::string id;
    {
      std::lock_guard lock(w.mutex);
      id = w.id;
    }
    if (id.empty()) {
      const auto t = Clock::now();
      try {
        const Registration r = w.link.registerWorker(
            WorkerInfo{"sim-" + std::to_string(index), 1, kProtocolVersion, kRendererVersion, 0, {}});
        record(tally.registerWorker, t);
        std::lock_guard lock(w.mutex);
        if (r.heartbeatIntervalSeconds > 0) w.heartbeatInterval = r.heartbeatIntervalSeconds;
        if (!w.registeredOnce) {
          w.registeredOnce = true;
          ++registered_;
        }
        w.id = r.workerId;
      } catch (const std::exception& e) {
        fail(tally, "RegisterWorker", e);
        backOff();
      }
      continue;
    }
    std::optional<LeaseGrant> grant;
    const auto t = Clock::now();
    try {
      grant = w.link.lease(id, config_.leaseWaitSeconds);
      ++leaseCalls_;
      backoff = 0.1;
    } catch (const FarmError& e) {
      if (e.kind() == FarmError::Kind::kUnknownWorker) forget(id);
      fail(tally, "LeaseWork", e);
      continue;
    } catch (const std::exception& e) {
      fail(tally, "LeaseWork", e);
      backOff();
      continue;
    }
    if (!grant) {
      ++tally.emptyLeases;
      continue;
    }
    record(tally.leaseGranted, t);
    {
      std::lock_guard lock(w.mutex);
      w.lease = grant->leaseId;
    }
    if (std::find(jobsSeen.begin(), jobsSeen.end(), grant->jobId) == jobsSeen.end()) {
      const auto s = Clock::now();  // lensfarm-worker fetches each job's spec once
      try {
        w.link.jobSpec(grant->jobId);
        record(tally.jobSpec, s);
        jobsSeen.push_back(grant->jobId);
      } catch (const std::exception& e) {
        fail(tally, "GetJobSpec", e);
      }
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(config_.renderSeconds * jitter(rng)));  // "render"
    const PixelRegion& region = grant->unit.region;
    const uint64_t unitBytes = (region.empty() ? uint64_t(config_.width) * uint64_t(config_.height)
                                               : uint64_t(region.width) * uint64_t(region.height)) *
                               3 * sizeof(double);
    if (config_.maxUnitBytes > 0 && unitBytes > config_.maxUnitBytes) {
      oversized_ = unitBytes;
      stop_ = true;
      break;
    }
    SensorBuffer kept = std::move(result.buffer);  // reused: its size changes only with the region's
    result = resultForLease(id, *grant);
    result.buffer = std::move(kept);
    fillUnit(grant->unit, config_.width, config_.height, result);
    result.renderSeconds = config_.renderSeconds;
    const auto u = Clock::now();
    try {
      const bool counted = w.link.upload(result);
      record(tally.upload, u);
      tally.bytesUploaded += result.buffer.sums.size() * sizeof(double);
      tally.largestUnitCells = std::max<uint64_t>(tally.largestUnitCells, result.buffer.cells());
      if (counted) {
        ++tally.unitsAccepted;
        tally.acks.push_back(Clock::now());
      } else {
        ++tally.duplicates;
      }
    } catch (const FarmError& e) {
      if (e.kind() == FarmError::Kind::kUnknownWorker) forget(id);
      ++tally.refused;
      ++tally.failures["UploadResult refused: " + std::string(e.what()).substr(0, 100)];
    } catch (const std::exception& e) {
      fail(tally, "UploadResult", e);
      backOff();
    }
    std::lock_guard lock(w.mutex);
    w.lease.reset();
  }
}

}  // namespace lensfarm::scale
