#include "coordinator/core/event_feed.h"

#include <algorithm>
#include <chrono>

namespace lensfarm {

uint64_t EventFeed::publish(FarmEvent event) {
  std::lock_guard lock(mutex_);
  event.sequence = next_++;
  event.unixSeconds = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  events_.push_back(std::move(event));
  while (events_.size() > capacity_) events_.pop_front();
  if (sink_) sink_(events_.back());
  published_.notify_all();
  return events_.back().sequence;
}

std::vector<FarmEvent> EventFeed::after(uint64_t after, size_t max, std::chrono::milliseconds wait) const {
  std::unique_lock lock(mutex_);
  published_.wait_for(lock, wait, [&] { return next_ - 1 > after; });
  std::vector<FarmEvent> out;
  // Sequences are consecutive: the first one wanted is at a known offset.
  const uint64_t first = events_.empty() ? next_ : events_.front().sequence;
  const uint64_t skip = after >= first ? after - first + 1 : 0;
  for (size_t i = size_t(std::min<uint64_t>(skip, events_.size())); i < events_.size() && out.size() < max; ++i)
    out.push_back(events_[i]);
  return out;
}

void EventFeed::restore(std::vector<FarmEvent> events) {
  std::lock_guard lock(mutex_);
  for (FarmEvent& e : events) {
    if (e.sequence < next_) continue;  // (out of order or twice: a damaged table; kept once, in order)
    next_ = e.sequence + 1;
    events_.push_back(std::move(e));
  }
  while (events_.size() > capacity_) events_.pop_front();
}

void EventFeed::setSink(std::function<void(const FarmEvent&)> sink) {
  std::lock_guard lock(mutex_);
  sink_ = std::move(sink);
}

uint64_t EventFeed::latest() const {
  std::lock_guard lock(mutex_);
  return next_ - 1;
}

uint64_t EventFeed::oldest() const {
  std::lock_guard lock(mutex_);
  return events_.empty() ? next_ : events_.front().sequence;
}

}  // namespace lensfarm
