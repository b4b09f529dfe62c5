#pragma once
// How the farm schedules a job, beside what it renders (JobSpec): what it waits for, which
// workers may render it, how many at once and its weight among its owner's jobs
// (docs/farm.md "Scheduling"). Fixed at submission and never changed; pausing and approval are
// the job's state, not its policy. Workers never see it: a job's bits do not depend on it.
//
// Conventions: a tag is 1 to 64 characters of [a-z0-9._-] starting with a letter or digit
// (a worker's --tags, a job's --require / --prefer); a dependency's error is a relative RMSE
// as a fraction (0.02 is 2 %), the measure of film/convergence.h.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace lensfarm {

// One job waited for: "job-7" (done), "job-7:failed", "job-7:ended", "job-7:approved",
// "job-7:error<=2%" (its estimated relative RMSE at or below 2 %, while it runs or once done).
struct Dependency {
  enum class Condition { kDone, kFailed, kEnded, kErrorAtMost, kApproved };
  std::string jobId;
  Condition condition = Condition::kDone;
  double maxError = 0.0;  // kErrorAtMost: the relative RMSE, a fraction in (0, 1]
  bool operator==(const Dependency&) const = default;
};

// What a job does when a dependency can no longer hold (the job it waits for was cancelled,
// failed, or ended above the error it waits for): fail with the reason, or wait (listed, with
// the reason, until a person cancels it).
enum class OnDependencyFailure { kFail, kWait };

// What a job does when its failures reach its limits (a unit failed on maxUnitFailures workers,
// or no worker is left that has not failed it): fail, or pause itself with the reason (resuming it
// forgets its failures and tries again).
enum class OnFailure { kFail, kPause };

struct JobPolicy {
  std::vector<Dependency> after;  // every one must hold before its first unit is leased
  OnDependencyFailure onDependencyFailure = OnDependencyFailure::kFail;
  std::vector<std::string> requireTags;       // a worker renders it only with all of these
  std::vector<std::string> preferTags;        // ...and one without them only while no idle worker has them
  std::vector<std::string> auditRequireTags;  // an audit of it only by a worker with all of these
  std::optional<uint32_t> maxWorkers;         // at most this many workers at once; unset: no cap
  double shareWeight = 1.0;                   // its share among its owner's jobs (fair share)
  // Failures (docs/farm.md "Failures"); unset: the coordinator's --max-unit-failures,
  // --max-failures-per-worker and --max-lease (a unit's longest time, after which its lease lapses
  // and counts as a failure of that worker).
  std::optional<uint32_t> maxUnitFailures, maxWorkerFailures;
  std::optional<double> unitTimeLimitSeconds;
  OnFailure onFailure = OnFailure::kFail;
  bool operator==(const JobPolicy&) const = default;
};

// "job-7:error<=2%" and back. parseDependency: FarmError kInvalidArgument naming `field` and the
// text for an empty job id, an unknown condition or an error outside (0, 100 %].
Dependency parseDependency(const std::string& text, const std::string& field);
std::string dependencyText(const Dependency& dependency);

// FarmError kInvalidArgument naming the field ("require_tags[1]: ...") for a tag that is not a
// tag, a cap of 0, a weight that is not a positive finite number, more than kMaxDependencies
// dependencies, a job waited for twice; the tags' spelling is kept (no lower-casing).
void checkPolicy(const JobPolicy& policy);
inline constexpr size_t kMaxDependencies = 64;
inline constexpr size_t kMaxTags = 32;
// FarmError kInvalidArgument naming `field` unless `tag` is a tag (conventions above).
void checkTag(const std::string& tag, const std::string& field);
// Whether `have` holds every tag of `need`.
bool hasAllTags(const std::vector<std::string>& have, const std::vector<std::string>& need);
// "a, b" (or "none").
std::string tagsText(const std::vector<std::string>& tags);

// The policy as the state dir keeps it (a JSON object) and back; a damaged text reads as the
// default policy with `*damage` saying why (the job is still restored).
std::string policyToJson(const JobPolicy& policy);
JobPolicy policyFromJson(const std::string& text, std::string* damage = nullptr);

}  // namespace lensfarm
