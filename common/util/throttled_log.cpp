#include "common/util/throttled_log.h"

#include <spdlog/spdlog.h>

namespace lensfarm {

void ThrottledLog::warn(const std::string& kind, const std::string& line) {
  const auto now = std::chrono::steady_clock::now();
  uint64_t heldBack = 0;
  {
    std::lock_guard lock(mutex_);
    Budget& budget = kinds_[kind];
    if (budget.written == 0 || now - budget.windowStart >= window_) {
      heldBack = budget.heldBack;
      budget = Budget{now, 0, 0, budget.heldBackTotal};
    }
    if (budget.written >= burst_) {
      ++budget.heldBack;
      ++budget.heldBackTotal;
      return;
    }
    ++budget.written;
  }
  if (heldBack > 0)
    spdlog::warn("{} (and {} more like it not logged in the {} s before)", line, heldBack, window_.count());
  else
    spdlog::warn("{}", line);
}

uint64_t ThrottledLog::suppressed(const std::string& kind) const {
  std::lock_guard lock(mutex_);
  const auto it = kinds_.find(kind);
  return it == kinds_.end() ? 0 : it->second.heldBackTotal;
}

}  // namespace lensfarm
