#pragma once
// The cross-worker audit (docs/farm.md "Audit"). A unit is deterministic: its result depends on
// the job and the unit's index alone (counter-based random numbers keyed by pixel, sample and
// dimension), so any two honest workers of one renderer version return the same sums, bit for
// bit on one instruction set and within float-summation tolerance across them. A fraction of
// the units counted into a job's film is therefore rendered again by a different worker and
// compared; when the two disagree, a third worker says which one is wrong.
//
// An AuditBook holds one job's units under audit and settles each one from the results that
// come back. It is a plain class with no lock and no network code: a Job's is guarded by
// Coordinator::mutex_, which also owns what follows from a verdict (the wrong worker's
// quarantine, the film's rewind; results.cpp).
//
// Invariants:
//  - A unit under audit is rendered again only by a worker that has not rendered it.
//  - A verdict names a wrong worker only when two other workers agree with each other and both
//    disagree with it (a majority of three); two results that disagree with no third one to
//    settle them name nobody.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace lensfarm {

// Where two results of one unit differ by more than `tolerance`, relative per cell and channel
// (|a - b| > tolerance * max(|a|, |b|)); nullopt when they agree everywhere. The text gives the
// largest relative difference and its cell: "differ by up to 1.0e-03 (cell 4711)", cells holding
// `channels` sums (film/sensor.h). Results of different sizes differ.
std::optional<std::string> sumsDiffer(const std::vector<double>& a, const std::vector<double>& b, double tolerance,
                                      int channels = 3);

// Whether the difference between two results of one unit looks like two machines' rounding, not
// a wrong result: at most kRoundingCells of the cells differ beyond `tolerance`, and the
// difference's relative RMSE (over all sums) is at most kRoundingRmse. Embree's kernels for
// different instruction sets differ so (measured: at most 0.4 % of the cells, relative RMSE at
// most 8e-5; docs/farm.md "Mixed machines"); a worker that skipped samples, traced another seed
// or returned garbage differs in most cells.
constexpr double kRoundingCells = 0.02, kRoundingRmse = 1e-3;
bool differenceLooksLikeRounding(const std::vector<double>& a, const std::vector<double>& b, double tolerance,
                                 int channels = 3);

// While auditing, a job's film keeps a copy of itself every rewindPointSpacing(fraction) units, at
// most kRewindPoints at once (Accumulator::keepRewindPoints): a wrong worker found costs the
// units summed since the latest copy before its first unaudited one (docs/farm.md "Audit").
constexpr size_t kRewindPoints = 3;
uint64_t rewindPointSpacing(double auditFraction);

class AuditBook {
 public:
  using Sums = std::shared_ptr<const std::vector<double>>;
  // A worker's result for a unit.
  struct Claim {
    std::string worker;
    Sums sums;
  };
  struct Audit {
    Claim counted;                     // the result in the film
    uint64_t acceptedSeq = 0;          // when it was accepted (Coordinator's acceptance sequence)
    std::optional<Claim> dissent;      // a second result that disagreed with it: a third decides
    std::set<std::string> renderedBy;  // the workers that rendered it or hold its audit lease
    std::optional<std::string> leasedTo;
  };

  // What a result for a unit under audit decided.
  struct Verdict {
    enum class Kind {
      kAgreed,        // it agrees with the counted result: both workers are right
      kDisputed,      // it disagrees with the counted result: a third worker will decide
      kSettled,       // it agrees with one of two that disagreed: the other is wrong
      kInconclusive,  // three results, no two agree
    };
    Kind kind = Kind::kAgreed;
    uint64_t unit = 0;
    uint64_t acceptedSeq = 0;        // the counted result's
    std::vector<std::string> right;  // the workers whose results agreed
    std::string wrong;               // kSettled: the worker out-voted
    std::string detail;              // the difference found ("differ by up to ...")
  };

  bool empty() const { return audits_.empty(); }
  size_t size() const { return audits_.size(); }
  bool contains(uint64_t unit) const { return audits_.count(unit) > 0; }
  const Audit* find(uint64_t unit) const;
  const std::map<uint64_t, Audit>& audits() const { return audits_; }

  // Puts counted unit `unit` under audit.
  void open(uint64_t unit, Claim counted, uint64_t acceptedSeq);
  // Whether a unit under audit waits for a worker like `worker` (see lease).
  bool offers(const std::string& worker) const;
  // A unit under audit that `worker` may render (one it has not rendered and nobody holds),
  // lowest first, now leased to it; nullopt if none.
  std::optional<uint64_t> lease(const std::string& worker);
  // The audit lease of `unit` held by `worker` ended without a result (lapsed, revoked, failed):
  // the unit may be leased again, to this worker too.
  void release(uint64_t unit, const std::string& worker);
  // `claim` is the result of the audit lease of `unit`; `fromCounted` and `fromDissent` are
  // sumsDiffer() of it against the counted result and the dissent (if any). Closes the audit
  // unless the verdict is kDisputed. nullopt if the unit is no longer under audit.
  std::optional<Verdict> settle(uint64_t unit, Claim claim, const std::optional<std::string>& fromCounted,
                                const std::optional<std::string>& fromDissent);
  // `worker` is quarantined: audits of its results are closed (they are rendered again), a
  // dissent of its is withdrawn, its audit leases released.
  void forgetWorker(const std::string& worker);
  void close(uint64_t unit) { audits_.erase(unit); }
  void clear() { audits_.clear(); }

 private:
  std::map<uint64_t, Audit> audits_;
};

}  // namespace lensfarm
