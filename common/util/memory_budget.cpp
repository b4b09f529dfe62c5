#include "common/util/memory_budget.h"

#include <algorithm>
#include <vector>

#include "common/util/byte_size.h"

namespace lensfarm {

MemoryBudget::Reservation::Reservation(Reservation&& other) noexcept
    : budget_(std::move(other.budget_)), id_(other.id_), bytes_(other.bytes_) {
  other.id_ = other.bytes_ = 0;
}

MemoryBudget::Reservation& MemoryBudget::Reservation::operator=(Reservation&& other) noexcept {
  if (this != &other) {
    release();
    budget_ = std::move(other.budget_);
    id_ = other.id_;
    bytes_ = other.bytes_;
    other.id_ = other.bytes_ = 0;
  }
  return *this;
}

void MemoryBudget::Reservation::release() {
  if (budget_) budget_->release(id_);
  budget_.reset();
  id_ = bytes_ = 0;
}

void MemoryBudget::Reservation::rename(const std::string& what) {
  if (budget_) budget_->rename(id_, what);
}

void MemoryBudget::rename(uint64_t id, const std::string& what) {
  std::lock_guard lock(mutex_);
  if (const auto it = held_.find(id); it != held_.end()) it->second.first = what;
}

std::shared_ptr<MemoryBudget> MemoryBudget::create(uint64_t total) {
  std::shared_ptr<MemoryBudget> budget(new MemoryBudget(total));
  budget->self_ = budget;
  return budget;
}

bool MemoryBudget::fits(uint64_t bytes) const {
  return total_ == 0 || (bytes <= total_ && reserved_ <= total_ - bytes);
}

MemoryBudget::Reservation MemoryBudget::grant(uint64_t bytes, const std::string& what) {
  Reservation r;
  r.budget_ = self_.lock();
  r.id_ = next_++;
  r.bytes_ = bytes;
  reserved_ += bytes;
  held_[r.id_] = {what, bytes};
  return r;
}

std::optional<MemoryBudget::Reservation> MemoryBudget::tryReserve(uint64_t bytes, const std::string& what) {
  std::lock_guard lock(mutex_);
  if (!fits(bytes)) return std::nullopt;
  return grant(bytes, what);
}

std::optional<MemoryBudget::Reservation> MemoryBudget::reserve(uint64_t bytes, const std::string& what,
                                                               std::chrono::milliseconds wait) {
  std::unique_lock lock(mutex_);
  if (total_ != 0 && bytes > total_) return std::nullopt;
  if (!freed_.wait_for(lock, wait, [&] { return fits(bytes); })) return std::nullopt;
  return grant(bytes, what);
}

MemoryBudget::Reservation MemoryBudget::force(uint64_t bytes, const std::string& what) {
  std::lock_guard lock(mutex_);
  return grant(bytes, what);
}

void MemoryBudget::release(uint64_t id) {
  {
    std::lock_guard lock(mutex_);
    const auto it = held_.find(id);
    if (it == held_.end()) return;
    reserved_ -= it->second.second;
    held_.erase(it);
  }
  freed_.notify_all();
}

uint64_t MemoryBudget::reserved() const {
  std::lock_guard lock(mutex_);
  return reserved_;
}

std::string MemoryBudget::describe(size_t largest) const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<std::string, uint64_t>> holders;
  for (const auto& [id, held] : held_) holders.push_back(held);
  std::stable_sort(holders.begin(), holders.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  std::string out = "holds " + formatBytes(reserved_) + (total_ ? " of its " + formatBytes(total_) : "");
  uint64_t rest = 0;
  for (size_t k = 0; k < holders.size(); ++k) {
    if (k < largest)
      out += (k == 0 ? ": " : ", ") + holders[k].first + " " + formatBytes(holders[k].second);
    else
      rest += holders[k].second;
  }
  if (holders.size() > largest) out += ", " + std::to_string(holders.size() - largest) + " more " + formatBytes(rest);
  return out;
}

}  // namespace lensfarm
