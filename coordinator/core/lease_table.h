#pragma once
// The coordinator's active leases: which worker holds which unit of which job, and until when.
// No network code and no lock of its own: Coordinator::mutex_ is held around every call. What a
// lease's end means for its job and worker (queued again, counted as expired) is the caller's
// (scheduler.cpp).
//
// Invariants:
//  - A lease id is random (53 bits from the operating system's generator, so that it survives a
//    JSON number), never 0 and never that of a lease held now: one worker's ids say nothing of
//    another's, and an id of an earlier run names no lease of this one.
//  - Only the worker a lease names may extend it, upload under it or report it failed.
//  - No lease outlives its longest end (granted + Options::maxLeaseSeconds), however often it is
//    extended: a worker that heartbeats without ever uploading loses its units.
//  - A unit has at most two leases that are not audits: its lease and, near a job's end, one backup
//    on a faster worker (Coordinator::tryBackupLease). The first result counts; the unit's other
//    lease ends then (eraseOthersOf), so its holder is told at its next heartbeat.
#include <chrono>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace lensfarm {

class LeaseTable {
 public:
  using Clock = std::chrono::steady_clock;
  struct Lease {
    std::string workerId;
    std::string jobId;
    uint64_t unit;
    Clock::time_point deadline;
    Clock::time_point longestEnd;  // the deadline never moves past this
    bool audit = false;            // renders a counted unit again (docs/farm.md "Audit"); the worker is not told
    Clock::time_point granted{};
  };

  // A new lease; returns its id.
  uint64_t grant(const std::string& workerId, const std::string& jobId, uint64_t unit, Clock::time_point deadline,
                 Clock::time_point longestEnd, bool audit = false);
  // The lease `id`, or null.
  const Lease* find(uint64_t id) const;

  // Whether lease `id` is held by `workerId`.
  bool heldBy(uint64_t id, const std::string& workerId) const;
  // Whether lease `id` is held by `workerId` for unit `unit` of `jobId`: what an upload under it must match.
  bool covers(uint64_t id, const std::string& workerId, const std::string& jobId, uint64_t unit) const;
  // Moves the deadline of lease `id` (at most to its longest end) if `workerId` holds it; false
  // if it does not (it must drop it).
  bool extend(uint64_t id, const std::string& workerId, Clock::time_point deadline);

  void erase(uint64_t id);
  // The leases of unit `unit` of `jobId` that are not audits (its lease, and a backup), in id order.
  std::vector<uint64_t> unitLeases(const std::string& jobId, uint64_t unit) const;
  // Ends every lease of that unit that is not an audit, but `keep`: the unit's first result is in.
  void eraseOthersOf(const std::string& jobId, uint64_t unit, uint64_t keep);
  // Removes and returns the leases whose deadline is before `now`, in id order.
  std::vector<std::pair<uint64_t, Lease>> takeExpired(Clock::time_point now);
  // Removes and returns the leases `workerId` holds, in id order.
  std::vector<Lease> takeAllOf(const std::string& workerId);
  void eraseAllOf(const std::string& jobId);
  // The same for the job's leases that are not audits.
  void eraseUnitsOf(const std::string& jobId);

  std::vector<const Lease*> ofJob(const std::string& jobId) const;  // in id order
  std::set<std::string> holders() const;                            // workers holding any lease
  size_t size() const { return leases_.size(); }

 private:
  std::map<uint64_t, Lease> leases_;
};

}  // namespace lensfarm
