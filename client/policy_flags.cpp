#include "client/policy_flags.h"

#include "common/farm/farm_types.h"
#include "common/util/error.h"

namespace lensfarm::cli {

void PolicyFlags::addTo(CLI::App* cmd) {
  cmd->add_option("--after", after,
                  "Wait for another job: JOB (done), JOB:failed, JOB:ended, JOB:approved or JOB:error<=2% "
                  "(repeat, or comma-separated, for several)")
      ->delimiter(',');
  cmd->add_option("--on-dependency-failure", onDependencyFailure,
                  "When a job waited for can no longer satisfy --after: fail this job, or wait until cancelled")
      ->check(CLI::IsMember({"fail", "wait"}))
      ->capture_default_str();
  cmd->add_option("--require", require, "Render only on workers with all these tags (comma-separated)")->delimiter(',');
  cmd->add_option("--prefer", prefer, "Prefer workers with all these tags: others render it only while none is idle")
      ->delimiter(',');
  cmd->add_option("--audit-require", auditRequire,
                  "Audit its units only on workers with all these tags (e.g. another CPU family)")
      ->delimiter(',');
  cmd->add_option("--max-workers", maxWorkers, "At most this many workers render it at once (default: no cap)");
  cmd->add_option("--share-weight", shareWeight, "Its share of the farm among your own jobs (fair share)")
      ->capture_default_str();
  cmd->add_option("--max-unit-failures", maxUnitFailures,
                  "Fail (or pause) the job when one unit failed on this many workers (default: the coordinator's)");
  cmd->add_option("--max-worker-failures", maxWorkerFailures,
                  "Failures of the job on one worker after which it is not leased the job again (default: the "
                  "coordinator's)");
  cmd->add_option("--unit-time-limit", unitTimeLimit,
                  "Seconds a unit may take; past it the lease lapses and counts as a failure of that worker");
  cmd->add_option("--on-failure", onFailure,
                  "When its failures reach those limits: fail the job, or pause it (resume tries again)")
      ->check(CLI::IsMember({"fail", "pause"}))
      ->capture_default_str();
}

JobPolicy PolicyFlags::toPolicy() const {
  JobPolicy p;
  for (size_t i = 0; i < after.size(); ++i) {
    try {
      p.after.push_back(parseDependency(after[i], "--after"));
    } catch (const FarmError& e) {
      throw InputError("--after", std::string(e.what()).substr(std::string("--after: ").size()));
    }
  }
  p.onDependencyFailure = onDependencyFailure == "wait" ? OnDependencyFailure::kWait : OnDependencyFailure::kFail;
  p.requireTags = require;
  p.preferTags = prefer;
  p.auditRequireTags = auditRequire;
  p.maxWorkers = maxWorkers;
  p.shareWeight = shareWeight;
  p.maxUnitFailures = maxUnitFailures;
  p.maxWorkerFailures = maxWorkerFailures;
  p.unitTimeLimitSeconds = unitTimeLimit;
  p.onFailure = onFailure == "pause" ? OnFailure::kPause : OnFailure::kFail;
  // The coordinator checks again; a mistake is said here first, by the flag's name.
  try {
    checkPolicy(p);
  } catch (const FarmError& e) {
    const std::string what = e.what();
    const std::string field = what.substr(0, what.find_first_of("[:"));
    const std::string flag = field == "require_tags"              ? "--require"
                             : field == "prefer_tags"             ? "--prefer"
                             : field == "audit_require_tags"      ? "--audit-require"
                             : field == "max_workers"             ? "--max-workers"
                             : field == "share_weight"            ? "--share-weight"
                             : field == "max_unit_failures"       ? "--max-unit-failures"
                             : field == "max_worker_failures"     ? "--max-worker-failures"
                             : field == "unit_time_limit_seconds" ? "--unit-time-limit"
                                                                  : "--after";
    throw InputError(flag, what.substr(what.find(": ") + 2));
  }
  return p;
}

}  // namespace lensfarm::cli
