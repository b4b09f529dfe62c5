#pragma once
// What went wrong for one job on its workers, and the rules that follow from it (docs/farm.md
// "Failures"): the failures workers reported, per worker and per unit, with their reasons (the
// oldest 16 kept, for the job's error); a worker that failed the job `maxPerWorker` times is
// blocklisted (not leased its units again); and the workers that went (lost or left) while
// holding its units, the last with what it held, so that the job can say why it stalls and
// announce one coming back.
//
// Not thread-safe: a Job's records are guarded by Coordinator::mutex_.
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace lensfarm {

class JobFailures {
 public:
  using Clock = std::chrono::steady_clock;
  // A worker gone while holding units of the job.
  struct Loss {
    std::string worker, verb, detail;  // "w1 (worker-3.1)", "lost", "connection closed"
    Clock::time_point when;
    std::vector<uint64_t> units;
  };

  // A failure of `unit` on worker `workerId`, `reason` naming both; the worker is blocklisted at
  // its `maxPerWorker`-th failure of the job. Returns how many different workers the unit has
  // failed on.
  size_t record(uint64_t unit, const std::string& workerId, const std::string& reason, uint32_t maxPerWorker);
  bool blocks(const std::string& workerId) const { return blocklist_.count(workerId) > 0; }
  // Forgets the failures, their reasons and the blocklist (a job resumed after its failure policy
  // paused it tries again); the workers gone are kept.
  void forgetFailures() {
    byWorker_.clear();
    unitFailedOn_.clear();
    reasons_.clear();
    blocklist_.clear();
  }
  std::string reasons() const;  // "; " between them, oldest first

  // Worker `name` (its id where unnamed) went holding units: the last loss is `loss`.
  void lost(const std::string& name, Loss loss, bool noteName);
  // Whether `name` had gone holding units of the job (it is then forgotten: announced once).
  bool rejoined(const std::string& name) { return gone_.erase(name) > 0; }
  const std::optional<Loss>& lastLoss() const { return lastLoss_; }

 private:
  static constexpr size_t kReasonsKept = 16;
  std::map<std::string, uint32_t> byWorker_;
  std::map<uint64_t, std::set<std::string>> unitFailedOn_;
  std::vector<std::string> reasons_;
  std::set<std::string> blocklist_;
  std::set<std::string> gone_;  // names (ids where unnamed) of workers gone holding its units
  std::optional<Loss> lastLoss_;
};

}  // namespace lensfarm
