#include "coordinator/core/job_failures.h"

namespace lensfarm {

size_t JobFailures::record(uint64_t unit, const std::string& workerId, const std::string& reason,
                           uint32_t maxPerWorker) {
  if (reasons_.size() < kReasonsKept) reasons_.push_back(reason);
  std::set<std::string>& failedOn = unitFailedOn_[unit];
  failedOn.insert(workerId);
  if (++byWorker_[workerId] >= maxPerWorker) blocklist_.insert(workerId);
  return failedOn.size();
}

std::string JobFailures::reasons() const {
  std::string out;
  for (const std::string& r : reasons_) out += (out.empty() ? "" : "; ") + r;
  return out;
}

void JobFailures::lost(const std::string& name, Loss loss, bool noteName) {
  if (noteName) gone_.insert(name);
  lastLoss_ = std::move(loss);
}

}  // namespace lensfarm
