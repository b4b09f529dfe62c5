#pragma once
// The coordinator's lock, with its rules written as Clang thread-safety annotations (Abseil's
// macros, as gRPC's own code uses them): a field says which lock guards it (ABSL_GUARDED_BY), a
// function which lock its caller must hold (ABSL_EXCLUSIVE_LOCKS_REQUIRED). Clang checks every
// access at compile time (-Wthread-safety; the test ThreadSafety.CoordinatorLockingIsCheckedByClang
// compiles coordinator/ with it); GCC ignores the annotations.
//
// Mutex is std::mutex with the annotations; MutexLock holds it for a scope (as std::lock_guard)
// and waits on condition variables with it held (as std::unique_lock).
#include <absl/base/thread_annotations.h>

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace lensfarm {

class ABSL_LOCKABLE Mutex {
 public:
  void lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() { mutex_.lock(); }
  void unlock() ABSL_UNLOCK_FUNCTION() { mutex_.unlock(); }
  // The lock is held here (for code the analysis cannot follow, e.g. a lambda run under the lock).
  void assertHeld() const ABSL_ASSERT_EXCLUSIVE_LOCK() {}
  std::mutex& native() { return mutex_; }

 private:
  std::mutex mutex_;
};

class ABSL_SCOPED_LOCKABLE MutexLock {
 public:
  explicit MutexLock(Mutex& mutex) ABSL_EXCLUSIVE_LOCK_FUNCTION(mutex) : lock_(mutex.native()) {}
  ~MutexLock() ABSL_UNLOCK_FUNCTION() {}
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // Lets go of the lock within the scope (slow work that needs no guarded state), and takes it back.
  void unlock() ABSL_UNLOCK_FUNCTION() { lock_.unlock(); }
  void lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() { lock_.lock(); }

  // The waits of std::condition_variable; the lock is held again when each returns. A predicate
  // reading guarded fields runs with the lock held (it calls Mutex::assertHeld to say so).
  template <class Predicate>
  void wait(std::condition_variable& cv, Predicate done) {
    cv.wait(lock_, done);
  }
  template <class Rep, class Period, class Predicate>
  bool waitFor(std::condition_variable& cv, std::chrono::duration<Rep, Period> timeout, Predicate done) {
    return cv.wait_for(lock_, timeout, done);
  }
  template <class Rep, class Period>
  void waitFor(std::condition_variable& cv, std::chrono::duration<Rep, Period> timeout) {
    cv.wait_for(lock_, timeout);
  }
  template <class Clock, class Duration>
  void waitUntil(std::condition_variable& cv, std::chrono::time_point<Clock, Duration> deadline) {
    cv.wait_until(lock_, deadline);
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace lensfarm
