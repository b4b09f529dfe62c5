// LeaseTable: the active leases, their holders and deadlines (lease_table.h).
#include "coordinator/core/lease_table.h"

#include <algorithm>
#include <random>

namespace lensfarm {

uint64_t LeaseTable::grant(const std::string& workerId, const std::string& jobId, uint64_t unit,
                           Clock::time_point deadline, Clock::time_point longestEnd, bool audit) {
  // std::random_device reads the operating system's generator (getrandom on Linux).
  thread_local std::random_device random;
  uint64_t id = 0;
  while (id == 0 || leases_.count(id))
    id = ((uint64_t(random()) << 32) | uint64_t(random())) & ((uint64_t(1) << 53) - 1);
  leases_[id] = Lease{workerId, jobId, unit, std::min(deadline, longestEnd), longestEnd, audit, Clock::now()};
  return id;
}

const LeaseTable::Lease* LeaseTable::find(uint64_t id) const {
  auto it = leases_.find(id);
  return it == leases_.end() ? nullptr : &it->second;
}

bool LeaseTable::heldBy(uint64_t id, const std::string& workerId) const {
  auto it = leases_.find(id);
  return it != leases_.end() && it->second.workerId == workerId;
}

bool LeaseTable::covers(uint64_t id, const std::string& workerId, const std::string& jobId, uint64_t unit) const {
  auto it = leases_.find(id);
  return it != leases_.end() && it->second.workerId == workerId && it->second.jobId == jobId && it->second.unit == unit;
}

bool LeaseTable::extend(uint64_t id, const std::string& workerId, Clock::time_point deadline) {
  auto it = leases_.find(id);
  if (it == leases_.end() || it->second.workerId != workerId) return false;
  it->second.deadline = std::min(deadline, it->second.longestEnd);
  return true;
}

void LeaseTable::erase(uint64_t id) { leases_.erase(id); }

std::vector<uint64_t> LeaseTable::unitLeases(const std::string& jobId, uint64_t unit) const {
  std::vector<uint64_t> out;
  for (const auto& [id, lease] : leases_)
    if (lease.jobId == jobId && lease.unit == unit && !lease.audit) out.push_back(id);
  return out;
}

void LeaseTable::eraseOthersOf(const std::string& jobId, uint64_t unit, uint64_t keep) {
  for (auto it = leases_.begin(); it != leases_.end();)
    it = it->first != keep && it->second.jobId == jobId && it->second.unit == unit && !it->second.audit
             ? leases_.erase(it)
             : std::next(it);
}

std::vector<std::pair<uint64_t, LeaseTable::Lease>> LeaseTable::takeExpired(Clock::time_point now) {
  std::vector<std::pair<uint64_t, Lease>> out;
  for (auto it = leases_.begin(); it != leases_.end();) {
    if (it->second.deadline < now) {
      out.emplace_back(it->first, std::move(it->second));
      it = leases_.erase(it);
    } else {
      ++it;
    }
  }
  return out;
}

std::vector<LeaseTable::Lease> LeaseTable::takeAllOf(const std::string& workerId) {
  std::vector<Lease> out;
  for (auto it = leases_.begin(); it != leases_.end();) {
    if (it->second.workerId != workerId) {
      ++it;
      continue;
    }
    out.push_back(std::move(it->second));
    it = leases_.erase(it);
  }
  return out;
}

void LeaseTable::eraseAllOf(const std::string& jobId) {
  for (auto it = leases_.begin(); it != leases_.end();)
    it = it->second.jobId == jobId ? leases_.erase(it) : std::next(it);
}

void LeaseTable::eraseUnitsOf(const std::string& jobId) {
  for (auto it = leases_.begin(); it != leases_.end();)
    it = it->second.jobId == jobId && !it->second.audit ? leases_.erase(it) : std::next(it);
}

std::vector<const LeaseTable::Lease*> LeaseTable::ofJob(const std::string& jobId) const {
  std::vector<const Lease*> out;
  for (const auto& [id, lease] : leases_)
    if (lease.jobId == jobId) out.push_back(&lease);
  return out;
}

std::set<std::string> LeaseTable::holders() const {
  std::set<std::string> out;
  for (const auto& [id, lease] : leases_) out.insert(lease.workerId);
  return out;
}

}  // namespace lensfarm
