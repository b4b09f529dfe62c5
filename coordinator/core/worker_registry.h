#pragma once
// The workers a coordinator knows, and the rules of a worker's identity: a registration issues an
// id ("worker-EPOCH.N", never reissued by this run) and a secret session the worker quotes with
// every call; a lost or departed worker's id is refused from then on (it must register again); a
// worker registering under the name of one that is gone replaces it; workers silent for long are
// forgotten. The records also carry what the scheduler and the audit note per worker.
//
// A worker with a per-machine credential (WorkerInfo::credential) is one identity for the run:
// every registration of the credential gets the same id and record (quarantine and counts kept,
// forgotten or not), with a new session, so the last registration supersedes the one before —
// whose session is refused from then on — and what the farm counts per worker id (a unit's
// failures, the blocklist, the audit's votes) counts the machine once.
//
// Not thread-safe: the Coordinator holds its registry under its lock (coordinator.h).
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "common/farm/farm_types.h"

namespace lensfarm {

// What a worker is doing, as the coordinator sees it.
enum class WorkerState {
  kRendering,  // holds a lease
  kIdle,       // heard from recently, holds nothing
  kStale,      // silent for longer than a few heartbeat intervals (not yet lost)
  kLost,       // its Attach stream broke, or (never attached) silent for longer than the lease timeout
  kLeft,       // it stopped cleanly
};
const char* workerStateName(WorkerState state);

struct WorkerRecord {
  std::string id;
  std::string session;         // secret, from registerWorker: what authenticateWorker compares
  uint64_t registrations = 1;  // of its credential, this run (1 without a credential)
  WorkerInfo info;
  std::chrono::steady_clock::time_point lastHeartbeat;
  std::string currentJobId;
  uint64_t unitsDone = 0;
  uint64_t failures = 0;  // units it reported failed
  std::optional<uint64_t> currentUnit;
  double samplesPerSecond = 0.0;
  // Liveness (attachWorker, workerLost, workerLeft).
  uint64_t attachment = 0;          // the Attach stream it holds; 0: none
  std::optional<WorkerState> gone;  // kLost or kLeft: its id is refused from then on
  std::chrono::steady_clock::time_point goneAt;
  std::string goneReason;
  // The audit (auditing.cpp): its counted units with an acceptance sequence up to `clearedSeq`
  // are vouched for by a later audit that agreed; its first counted unit is always audited.
  uint64_t clearedSeq = 0;
  bool firstUnitAudited = false;
  uint64_t auditsPassed = 0;    // its own counted units an audit confirmed
  uint64_t auditsRendered = 0;  // units it rendered again for another worker's audit, which agreed
  bool quarantined = false;     // leased nothing more
  std::string quarantineReason;
  // Jobs whose assets it was asked to fetch ahead (Coordinator::prefetchJob): it may fetch their
  // spec and assets without a lease.
  std::set<std::string> prefetched;
  std::string label() const { return info.name.empty() ? id : info.name + " (" + id + ")"; }
};

class WorkerRegistry {
 public:
  using Clock = std::chrono::steady_clock;
  using Map = std::map<std::string, std::unique_ptr<WorkerRecord>>;

  void setEpoch(uint64_t epoch) { epoch_ = epoch; }
  // A new worker, heard from at `now`. `*replacedGone`: a lost or departed worker of the same
  // name was replaced by it (its jobs say it rejoined). With a credential, the credential's record
  // afresh; the caller releases what a live one held first (byCredential).
  WorkerRecord& add(const WorkerInfo& info, Clock::time_point now, bool* replacedGone);
  // The live worker registered with `credential`, or null.
  WorkerRecord* liveByCredential(const std::string& credential);
  // The worker, alive: FarmError kUnknownWorker if unknown, lost or left ("register again").
  WorkerRecord& find(const std::string& id);
  // The worker if known and alive, else null; the record whatever its state, else null.
  WorkerRecord* live(const std::string& id);
  WorkerRecord* known(const std::string& id);
  const WorkerRecord* known(const std::string& id) const;
  // The session is the one issued to `id` (compared in constant time): kUnauthenticated for none,
  // kPermissionDenied for another.
  void authenticate(const std::string& id, const std::string& session);
  std::string labelOf(const std::string& id) const;  // "name (id)", or the id of an unknown worker
  // Drops the workers not heard from for `forgetAfter`: they hold nothing any more.
  void forgetSilent(Clock::time_point now, Clock::duration forgetAfter);

  Map::const_iterator begin() const { return workers_.begin(); }
  Map::const_iterator end() const { return workers_.end(); }
  size_t size() const { return workers_.size(); }

 private:
  Map workers_;
  uint64_t epoch_ = 0;
  uint64_t next_ = 1;
};

}  // namespace lensfarm
