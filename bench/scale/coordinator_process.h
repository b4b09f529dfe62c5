#pragma once
// The real lensfarm-coordinator binary as a child process of the scale test, so
// that its CPU time and memory are read from /proc/<pid> apart from the
// simulated workers': a temp state dir, client and worker tokens, gRPC and
// Prometheus metrics on free loopback ports.
//
// Units: CPU time in seconds (utime + stime of /proc/<pid>/stat over the clock
// tick), memory in bytes (VmRSS, VmHWM of /proc/<pid>/status, which the kernel
// counts in KiB).
#include <sys/types.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lensfarm::scale {

class CoordinatorProcess {
 public:
  // Starts `binary` with `extraArgs` and waits (at most 30 s) until it serves;
  // throws with its log if it exits or does not.
  CoordinatorProcess(const std::filesystem::path& binary, const std::vector<std::string>& extraArgs);
  ~CoordinatorProcess();  // SIGKILL, reaped, and the temp dir removed
  CoordinatorProcess(const CoordinatorProcess&) = delete;
  CoordinatorProcess& operator=(const CoordinatorProcess&) = delete;

  const std::string& address() const { return address_; }
  const std::string& clientToken() const { return clientToken_; }
  const std::string& workerToken() const { return workerToken_; }
  pid_t pid() const { return pid_; }
  bool running();

  double cpuSeconds() const;           // user + system, since it started
  uint64_t residentBytes() const;      // VmRSS now
  uint64_t peakResidentBytes() const;  // VmHWM: the most it has held resident
  // Its Prometheus exposition (GET /metrics), as "name{labels}" -> value;
  // throws if unreachable.
  std::map<std::string, double> metrics() const;
  std::string log() const;  // stderr so far
  // Leaves the temp dir (state dir, stdout, stderr) in place when the process goes; returns it.
  std::string keepFiles() {
    keep_ = true;
    return dir_.string();
  }

 private:
  void stop();  // what the destructor does
  std::filesystem::path dir_;
  pid_t pid_ = -1;
  bool reaped_ = false, keep_ = false;
  std::string address_, metricsAddress_, clientToken_, workerToken_;
};

}  // namespace lensfarm::scale
