#pragma once
// The submit command's scheduling flags (docs/farm.md "Scheduling"), as a JobPolicy
// (farm/job_policy.h): --after, --on-dependency-failure, --require, --prefer, --audit-require,
// --max-workers, --share-weight, --max-unit-failures, --max-worker-failures, --unit-time-limit,
// --on-failure.
#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/farm/job_policy.h"

namespace lensfarm::cli {

struct PolicyFlags {
  std::vector<std::string> after;
  std::string onDependencyFailure = "fail";
  std::vector<std::string> require, prefer, auditRequire;
  std::optional<uint32_t> maxWorkers;
  double shareWeight = 1.0;
  std::optional<uint32_t> maxUnitFailures, maxWorkerFailures;
  std::optional<double> unitTimeLimit;
  std::string onFailure = "fail";

  void addTo(CLI::App* cmd);
  // InputError naming the flag for a bad dependency, tag, cap or weight.
  JobPolicy toPolicy() const;
};

}  // namespace lensfarm::cli
