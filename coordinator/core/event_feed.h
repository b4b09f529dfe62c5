#pragma once
// The coordinator's feed of FarmEvents (farm/farm_event.h), in order: served by ListEvents (gRPC),
// the HTTP API's Server-Sent Events stream and the webhooks (docs/api.md "Events").
//
// Invariant: sequence numbers start at 1 and grow by one per event, so a reader that has seen
// event N asks for those after N and misses none while they are held; the feed holds the newest
// `capacity` events (the oldest dropped), and a reader that fell behind learns it from
// `oldest()` > its cursor + 1.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "common/farm/farm_event.h"

namespace lensfarm {

// Thread-safe; publish() takes only the feed's own lock, so it may be called under any other.
class EventFeed {
 public:
  explicit EventFeed(size_t capacity = 4096) : capacity_(capacity) {}

  // Appends the event (its sequence and time assigned), hands it to the sink, and returns its
  // sequence.
  uint64_t publish(FarmEvent event);
  // Durable events (with a state dir): the events kept before a restart, oldest first (numbering
  // goes on after the last), and what keeps each new one. The sink runs under the feed's lock, so
  // it sees events in order; it must not throw.
  void restore(std::vector<FarmEvent> events);
  void setSink(std::function<void(const FarmEvent&)> sink);
  size_t capacity() const { return capacity_; }
  // The held events with sequence > `after`, oldest first, at most `max`; when there is none,
  // waits up to `wait` for one.
  std::vector<FarmEvent> after(uint64_t after, size_t max,
                               std::chrono::milliseconds wait = std::chrono::milliseconds(0)) const;
  uint64_t latest() const;  // the last sequence given; 0 before the first event
  uint64_t oldest() const;  // the oldest sequence held; latest() + 1 when none is

 private:
  size_t capacity_;
  mutable std::mutex mutex_;
  mutable std::condition_variable published_;
  std::deque<FarmEvent> events_;
  std::function<void(const FarmEvent&)> sink_;
  uint64_t next_ = 1;
};

}  // namespace lensfarm
