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
  // The coordinator checks again; a mistake is said here first, by the flag's name.
  try {
    checkPolicy(p);
  } catch (const FarmError& e) {
    const std::string what = e.what();
    const std::string field = what.substr(0, what.find_first_of("[:"));
    const std::string flag = field == "require_tags"         ? "--require"
                             : field == "prefer_tags"        ? "--prefer"
                             : field == "audit_require_tags" ? "--audit-require"
                             : field == "max_workers"        ? "--max-workers"
                             : field == "share_weight"       ? "--share-weight"
                                                             : "--after";
    throw InputError(flag, what.substr(what.find(": ") + 2));
  }
  return p;
}

}  // namespace lensfarm::cli
