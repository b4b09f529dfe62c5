#include "common/util/byte_size.h"

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <vector>

#include "common/util/error.h"

namespace lensfarm {

namespace {

// The number in a file such as memory.max ("max" or garbage: none).
uint64_t readLimit(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text.empty() || !std::isdigit(static_cast<unsigned char>(text[0]))) return 0;
  errno = 0;
  const unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
  return errno ? 0 : uint64_t(v);
}

// The cgroup's memory limit (0: none), v2 then v1, for this process's own cgroup and the root
// the container sees.
uint64_t cgroupLimit() {
  std::vector<std::string> candidates;
  std::ifstream self("/proc/self/cgroup");
  for (std::string line; std::getline(self, line);) {
    if (line.rfind("0::", 0) == 0) candidates.push_back("/sys/fs/cgroup" + line.substr(3) + "/memory.max");
    const size_t a = line.find(":memory:");
    if (a != std::string::npos)
      candidates.push_back("/sys/fs/cgroup/memory" + line.substr(a + 8) + "/memory.limit_in_bytes");
  }
  candidates.push_back("/sys/fs/cgroup/memory.max");
  candidates.push_back("/sys/fs/cgroup/memory/memory.limit_in_bytes");
  uint64_t limit = 0;
  for (const auto& c : candidates)
    if (const uint64_t v = readLimit(c); v > 0 && (limit == 0 || v < limit)) limit = v;
  return limit;
}

}  // namespace

uint64_t machineMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  uint64_t bytes = pages > 0 && pageSize > 0 ? uint64_t(pages) * uint64_t(pageSize) : 0;
  if (const uint64_t limit = cgroupLimit(); limit > 0 && (bytes == 0 || limit < bytes)) bytes = limit;
  return bytes > 0 ? bytes : std::numeric_limits<uint64_t>::max();
}

uint64_t defaultJobMemoryBudget() {
  if (const char* env = std::getenv("LENSFARM_MAX_JOB_MEMORY"); env && *env) {
    const uint64_t bytes = parseByteSize(env);
    if (bytes == 0)
      throw InputError("LENSFARM_MAX_JOB_MEMORY",
                       "expected a size such as 16G, 512MiB or 2000000000 (bytes), got \"" + std::string(env) + "\"");
    return bytes;
  }
  const uint64_t machine = machineMemoryBytes();
  return machine == std::numeric_limits<uint64_t>::max() ? machine : machine / 4 * 3;
}

std::string defaultJobMemoryBudgetSource() {
  if (const char* env = std::getenv("LENSFARM_MAX_JOB_MEMORY"); env && *env) return "LENSFARM_MAX_JOB_MEMORY";
  return "3/4 of this machine's " + formatBytes(machineMemoryBytes()) + " of memory";
}

uint64_t parseByteSize(const std::string& text) {
  size_t end = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &end);
  } catch (const std::exception&) {
    return 0;
  }
  if (!(value > 0.0) || !std::isfinite(value) || !std::isdigit(static_cast<unsigned char>(text[0]))) return 0;
  std::string unit;
  for (char c : text.substr(end))
    if (!std::isspace(static_cast<unsigned char>(c))) unit += char(std::toupper(static_cast<unsigned char>(c)));
  static const char* kPrefixes = "KMGT";
  double scale = 1.0;
  if (!unit.empty() && unit != "B") {
    const char* p = std::strchr(kPrefixes, unit[0]);
    if (!p || !*p) return 0;
    const std::string rest = unit.substr(1);
    const int power = int(p - kPrefixes) + 1;
    if (rest.empty() || rest == "IB")
      scale = std::pow(1024.0, power);
    else if (rest == "B")
      scale = std::pow(1000.0, power);
    else
      return 0;
  }
  const double bytes = value * scale;
  if (bytes < 1.0 || bytes >= 1.8e19) return 0;
  return uint64_t(bytes);
}

std::string formatBytes(uint64_t bytes) {
  static const char* kUnits[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  double v = double(bytes);
  int u = 0;
  while (v >= 1000.0 && u < 6) v /= 1000.0, ++u;
  char buf[32];
  if (u == 0)
    std::snprintf(buf, sizeof buf, "%llu bytes", (unsigned long long)bytes);
  else
    std::snprintf(buf, sizeof buf, v < 10.0 ? "%.2f %s" : v < 100.0 ? "%.1f %s" : "%.0f %s", v, kUnits[u]);
  return buf;
}

}  // namespace lensfarm
