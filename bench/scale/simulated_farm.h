#pragma once
// A farm of simulated workers for the scale test: one thread each, each with
// its own gRPC channel and TCP connection (as separate machines have), its own
// registration, Attach stream, long-polled leases and uploads of exactly the
// leased region, and heartbeats every interval the coordinator asks for (as
// lensfarm-worker's heartbeat thread; here a few pump threads send every
// worker's), filled with the known values of synthetic_image.h after sleeping
// for the unit's "render time". They trace nothing, so a thousand of them fit
// on two cores and the coordinator is what is measured. Each call's latency, as
// the worker sees it, is recorded.
//
// Units: times in seconds.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace lensfarm {
class GrpcCoordinatorLink;
}

namespace lensfarm::scale {

// Latencies of one RPC kind as the workers saw them.
struct CallTimes {
  std::vector<double> seconds;
  void add(double s) { seconds.push_back(s); }
  void merge(const CallTimes& o) { seconds.insert(seconds.end(), o.seconds.begin(), o.seconds.end()); }
  // The q-quantile (nearest rank) of the recorded times; 0 when none.
  double quantile(double q) const;
  double max() const;
  size_t count() const { return seconds.size(); }
};

// What the workers did and saw, summed over them.
struct FarmTally {
  uint64_t unitsAccepted = 0;                // uploads the coordinator acknowledged as counted
  uint64_t duplicates = 0;                   // uploads it acknowledged as already counted (ignored)
  uint64_t refused = 0;                      // uploads it refused (the lease had lapsed or been revoked)
  uint64_t emptyLeases = 0;                  // long polls that ended with no unit
  uint64_t failedCalls = 0;                  // calls that failed otherwise (timeouts, unavailable)
  std::map<std::string, uint64_t> failures;  // their messages (the call's name first), by count
  uint64_t bytesUploaded = 0;                // sums uploaded (8 bytes a double), acknowledged or not
  uint64_t largestUnitCells = 0;             // the cells of the largest region uploaded
  CallTimes registerWorker, leaseGranted, upload, heartbeat, jobSpec;
  // When each upload was acknowledged as counted (steady clock); audit renders
  // of counted units are acknowledged too, also after the job is done.
  std::vector<std::chrono::steady_clock::time_point> acks;
  // The last acknowledgment at or before `t`.
  std::chrono::steady_clock::time_point lastAckBy(std::chrono::steady_clock::time_point t) const;
  void merge(const FarmTally& o);
};

struct FarmConfig {
  std::string address, workerToken;
  int workers = 1000;
  int width = 0, height = 0;      // the job's frame: a pass unit covers all of it
  double renderSeconds = 0.2;     // a unit's "render" sleep, +-50 % uniformly per unit
  double leaseWaitSeconds = 2.0;  // the long poll of a lease request (as lensfarm-worker)
  double callTimeoutSeconds = 120.0;
  // A unit whose sums exceed this is not uploaded: the farm stops and says so (oversizedUnitBytes).
  // A coordinator that hands a thousand workers whole 4K frames (199 MB each) would otherwise
  // exhaust the machine's memory. 0: no limit.
  uint64_t maxUnitBytes = 0;
};

class SimulatedFarm {
 public:
  explicit SimulatedFarm(FarmConfig config);
  ~SimulatedFarm();  // stops and joins
  SimulatedFarm(const SimulatedFarm&) = delete;
  SimulatedFarm& operator=(const SimulatedFarm&) = delete;

  int registered() const { return registered_.load(); }
  uint64_t heartbeatsSent() const { return heartbeats_.load(); }
  uint64_t leaseCalls() const { return leaseCalls_.load(); }  // those answered (a unit or none)
  // The sums of a unit larger than FarmConfig::maxUnitBytes a worker was leased; 0 if none.
  uint64_t oversizedUnitBytes() const { return oversized_.load(); }
  // Records the latencies only of calls made from now on (to measure from the
  // job's submission).
  void measureFromNow();
  // Stops every worker (within a lease poll) and returns their sums.
  FarmTally stop();

 private:
  struct Worker;
  void run(int index);
  void pumpHeartbeats(int pump);
  // Adds a call's latency to `times` if it started after measureFromNow().
  void record(CallTimes& times, std::chrono::steady_clock::time_point start) const;
  FarmConfig config_;
  std::atomic<bool> stop_{false};
  std::atomic<int> registered_{0};
  std::atomic<uint64_t> heartbeats_{0}, leaseCalls_{0}, oversized_{0};
  std::atomic<std::chrono::steady_clock::rep> measureFrom_{0};  // steady-clock ticks
  std::vector<std::unique_ptr<Worker>> workers_;
  std::vector<FarmTally> tallies_;  // one per worker and one per pump, each
                                    // written by one thread until stop()
  std::vector<std::thread> threads_;
};

}  // namespace lensfarm::scale
