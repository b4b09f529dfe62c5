#include "coordinator/core/fair_share.h"

#include <algorithm>

namespace lensfarm {

double FairShare::ownerStart(const std::string& owner) const {
  const auto it = owners_.find(owner);
  return std::max(lastStart_, it == owners_.end() ? 0.0 : it->second.finish);
}

double FairShare::jobStart(const std::string& owner, const std::string& job) const {
  const auto it = owners_.find(owner);
  if (it == owners_.end()) return 0.0;
  const auto j = it->second.jobs.find(job);
  return std::max(it->second.lastStart, j == it->second.jobs.end() ? 0.0 : j->second);
}

void FairShare::charge(const std::string& owner, double ownerWeight, const std::string& job, double jobWeight,
                       double cost) {
  const double start = ownerStart(owner);
  const double jobAt = jobStart(owner, job);
  Owner& o = owners_[owner];
  o.finish = start + cost / std::max(ownerWeight, 1e-9);
  lastStart_ = start;
  o.jobs[job] = jobAt + cost / std::max(jobWeight, 1e-9);
  o.lastStart = jobAt;
}

void FairShare::forgetJob(const std::string& owner, const std::string& job) {
  const auto it = owners_.find(owner);
  if (it != owners_.end()) it->second.jobs.erase(job);
}

}  // namespace lensfarm
