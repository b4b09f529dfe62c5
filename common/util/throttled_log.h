#pragma once
// Warnings that anyone on the network can cause (a refused token, a refused request) written at
// a bounded rate: at most `burst` lines per kind in each window; the lines held back are counted
// and the next line written for that kind says how many there were. 10,000 refused calls in five
// seconds make a dozen lines, not 10,000, and still say that they happened.
#include <chrono>
#include <map>
#include <mutex>
#include <string>

namespace lensfarm {

class ThrottledLog {
 public:
  explicit ThrottledLog(size_t burst = 10, std::chrono::seconds window = std::chrono::seconds(10))
      : burst_(burst), window_(window) {}

  // Logs `line` at warn level unless `kind` (a fixed name, never text from a request: the table
  // holds one entry per kind) is over its budget for the current window.
  void warn(const std::string& kind, const std::string& line);

  // How many lines of `kind` were held back since the process started.
  uint64_t suppressed(const std::string& kind) const;

 private:
  struct Budget {
    std::chrono::steady_clock::time_point windowStart;
    size_t written = 0;
    uint64_t heldBack = 0, heldBackTotal = 0;
  };
  const size_t burst_;
  const std::chrono::seconds window_;
  mutable std::mutex mutex_;
  std::map<std::string, Budget> kinds_;
};

}  // namespace lensfarm
