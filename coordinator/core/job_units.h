#pragma once
// Where each unit of one job stands, for the scheduler and for result acceptance: waiting to be
// leased, being recorded (accepted, not yet durable), or counted. No network code and no lock
// of its own: a Job's is guarded by Coordinator::mutex_.
//
// Invariants:
//  - Units are leased lowest index first, those whose lease lapsed or was revoked before any
//    fresh one.
//  - A unit is counted at most once: acceptance refuses one that is counted or being recorded.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <set>

namespace lensfarm {

class JobUnits {
 public:
  JobUnits() = default;
  explicit JobUnits(uint64_t total) : total_(total) {}

  uint64_t total() const { return total_; }

  // ---- to lease ----
  // Every index from nextFresh() on, plus those queued again. Kept lazily so that a job of 2^40
  // samples costs no more than a small one.
  bool hasPending() const { return !returned_.empty() || nextFresh_ < total_; }
  bool hasReturned() const { return !returned_.empty(); }
  uint64_t nextFresh() const { return nextFresh_; }
  // The unit takePending() would return now (requires hasPending()).
  uint64_t peekPending() const { return returned_.empty() ? nextFresh_ : *returned_.begin(); }
  uint64_t takePending() {
    if (!returned_.empty()) {
      const uint64_t u = *returned_.begin();
      returned_.erase(returned_.begin());
      return u;
    }
    const uint64_t u = nextFresh_++;
    skipCounted();
    return u;
  }
  void requeue(uint64_t u) { returned_.insert(u); }
  void clearPending() {
    returned_.clear();
    nextFresh_ = total_;
  }
  // After a restart, with every unit of the ledger received: fresh units start above the highest
  // one (none: at 0), and those below it that were leased and never acknowledged are queued again.
  void resumeAfter(std::optional<uint64_t> highest) {
    nextFresh_ = highest ? *highest + 1 : 0;
    for (uint64_t u = receivedBelow_; highest && u < *highest; ++u)
      if (!isReceived(u)) returned_.insert(u);
  }

  // The audit found a wrong worker (docs/farm.md "Audit"): only units [0, units) and `kept` stay
  // counted; every other unit from `units` on is to lease again, in order. Returns how many
  // counted units that un-counts.
  uint64_t rewindTo(uint64_t units, const std::set<uint64_t>& kept) {
    uint64_t uncounted = 0;
    for (uint64_t u = units; u < receivedBelow_; ++u) uncounted += !kept.count(u);
    for (uint64_t u : receivedAbove_) uncounted += u >= units && !kept.count(u);
    receivedBelow_ = std::min(receivedBelow_, units);
    std::set<uint64_t> above;
    for (uint64_t u : receivedAbove_)
      if (u < units) above.insert(u);
    receivedAbove_ = std::move(above);
    for (uint64_t u : kept) markReceived(u);
    returned_.clear();
    nextFresh_ = std::min(nextFresh_, units);
    skipCounted();
    return uncounted;
  }

  // ---- accepted ----
  bool isRecording(uint64_t u) const { return inflight_.count(u) > 0; }
  void beginRecording(uint64_t u) { inflight_.insert(u); }
  void endRecording(uint64_t u) { inflight_.erase(u); }
  uint64_t countedPrefix() const { return receivedBelow_; }  // units [0, this) are all counted
  bool isReceived(uint64_t u) const { return u < receivedBelow_ || receivedAbove_.count(u); }
  void markReceived(uint64_t u) {
    receivedAbove_.insert(u);
    while (!receivedAbove_.empty() && *receivedAbove_.begin() == receivedBelow_) {
      receivedAbove_.erase(receivedAbove_.begin());
      ++receivedBelow_;
    }
  }

 private:
  // Fresh units are never counted, except those kept over a rewind.
  void skipCounted() {
    while (nextFresh_ < total_ && isReceived(nextFresh_)) ++nextFresh_;
  }

  uint64_t total_ = 0;
  uint64_t nextFresh_ = 0;
  std::set<uint64_t> returned_;
  std::set<uint64_t> inflight_;  // accepted, being made durable before they count
  // Units whose result was accepted (counted once): all below receivedBelow_, plus receivedAbove_.
  uint64_t receivedBelow_ = 0;
  std::set<uint64_t> receivedAbove_;
};

}  // namespace lensfarm
