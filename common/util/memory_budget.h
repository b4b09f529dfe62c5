#pragma once
// One budget of bytes for a whole process, shared by everything frame-sized it holds
// (docs/farm.md "Memory"). The coordinator reserves from it before it allocates: each job's film
// for the job's life, each image it develops for a download, snapshot or archive while that image
// lives, and — without a state dir — each uploaded asset and archived image. A reservation is a
// claim on bytes, returned when it is destroyed; what does not fit is refused (tryReserve) or
// waits for room (reserve), so the sum of what is held stays within the budget whatever clients
// do at once.
//
// Invariant: reserved() == the sum of the live reservations' bytes; reserved() <= total() except
// after force(), which admits what was accepted before a restart.
// Thread-safe; a leaf lock (nothing is called while it is held).
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace lensfarm {

class MemoryBudget {
 public:
  class Reservation {
   public:
    Reservation() = default;
    Reservation(Reservation&& other) noexcept;
    Reservation& operator=(Reservation&& other) noexcept;
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    ~Reservation() { release(); }
    uint64_t bytes() const { return bytes_; }
    void release();
    void rename(const std::string& what);  // e.g. once the job has its id

   private:
    friend class MemoryBudget;
    std::shared_ptr<MemoryBudget> budget_;
    uint64_t id_ = 0, bytes_ = 0;
  };

  // `total` bytes; 0: no limit (every reservation fits, and is still counted).
  static std::shared_ptr<MemoryBudget> create(uint64_t total);

  // `bytes` for `what` ("job-3", "a download of job-3") if they fit beside what is held now.
  std::optional<Reservation> tryReserve(uint64_t bytes, const std::string& what);
  // The same, waiting up to `wait` for room; nullopt if there was none by then (or the bytes can
  // never fit: more than the total).
  std::optional<Reservation> reserve(uint64_t bytes, const std::string& what, std::chrono::milliseconds wait);
  // Always granted, even past the total (what was accepted before a restart is held again).
  Reservation force(uint64_t bytes, const std::string& what);

  uint64_t total() const { return total_; }
  uint64_t reserved() const;
  // "holds 3.1 GB of its 16.0 GB: job-3 2.0 GB, job-7 1.0 GB, 2 more 100 MB": the largest
  // `largest` holders, for a refusal's message.
  std::string describe(size_t largest = 3) const;

 private:
  explicit MemoryBudget(uint64_t total) : total_(total) {}
  bool fits(uint64_t bytes) const;  // with mutex_ held
  Reservation grant(uint64_t bytes, const std::string& what);
  void release(uint64_t id);
  void rename(uint64_t id, const std::string& what);

  const uint64_t total_;
  std::weak_ptr<MemoryBudget> self_;
  mutable std::mutex mutex_;
  std::condition_variable freed_;
  uint64_t reserved_ = 0, next_ = 1;
  std::map<uint64_t, std::pair<std::string, uint64_t>> held_;  // id -> (what, bytes)
};

}  // namespace lensfarm
