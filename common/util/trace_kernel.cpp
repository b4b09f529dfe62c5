#include "common/util/trace_kernel.h"

#include <algorithm>
#include <cstdlib>
#include <sstream>
#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

namespace lensfarm {

namespace {

struct KernelRow {
  TraceKernel kernel;
  const char* name;
  const char* embreeIsa;  // Embree 3's `isa=` that selects it
};
// Narrowest first: the order kernels are ranked in.
constexpr KernelRow kKernels[] = {
    {TraceKernel::kSse2, "sse2", "sse2"},
    {TraceKernel::kAvx2, "avx2", "avx2"},
    {TraceKernel::kAvx512, "avx512", "avx512"},
    {TraceKernel::kNeon, "neon", "neon"},
};

const KernelRow& rowOf(TraceKernel kernel) {
  for (const KernelRow& row : kKernels)
    if (row.kernel == kernel) return row;
  return kKernels[0];
}

int rankOf(TraceKernel kernel) { return int(&rowOf(kernel) - kKernels); }

// LENSFARM_EMBREE_CONFIG split at commas into its settings, each trimmed.
std::vector<std::string> configSettings() {
  std::vector<std::string> settings;
  const char* env = std::getenv("LENSFARM_EMBREE_CONFIG");
  if (!env) return settings;
  std::stringstream in(env);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
    if (b != std::string::npos) settings.push_back(item.substr(b, e - b + 1));
  }
  return settings;
}

bool isIsaSetting(const std::string& setting) {
  return setting.rfind("isa", 0) == 0 && setting.find('=') != std::string::npos;
}

// The kernel an `isa=` of LENSFARM_EMBREE_CONFIG caps this machine to, if it names one. Embree's
// own names are accepted too: sse4.2 and avx give sse2's bits.
std::optional<TraceKernel> configCap() {
  for (const std::string& s : configSettings()) {
    if (!isIsaSetting(s)) continue;
    std::string isa = s.substr(s.find('=') + 1);
    isa.erase(0, isa.find_first_not_of(" \t"));
    if (isa == "sse4.2" || isa == "sse42" || isa == "sse4.1" || isa == "sse41" || isa == "avx")
      return TraceKernel::kSse2;
    return kernelNamed(isa);
  }
  return std::nullopt;
}

std::vector<TraceKernel> cpuKernels() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  std::vector<TraceKernel> kernels{TraceKernel::kSse2};
  // Embree 3's requirements for its AVX2 kernels (CPU_FEATURES_AVX2: AVX, F16C, AVX2, FMA3, BMI1,
  // BMI2, LZCNT) and its AVX-512 ones (CPU_FEATURES_AVX512SKX: those, and AVX-512 F, DQ, CD, BW,
  // VL); libgcc also checks that the operating system saves the registers (XGETBV).
  // LZCNT and F16C are read from CPUID itself: clang's __builtin_cpu_supports does not know them.
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0;
  const bool lzcnt = __get_cpuid(0x80000001u, &eax, &ebx, &ecx, &edx) && (ecx & bit_LZCNT) != 0;
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
                    __builtin_cpu_supports("bmi2") && lzcnt && f16c;
  if (avx2) kernels.push_back(TraceKernel::kAvx2);
  if (avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl"))
    kernels.push_back(TraceKernel::kAvx512);
  return kernels;
#else
  return {TraceKernel::kNeon};
#endif
}

}  // namespace

const char* kernelName(TraceKernel kernel) { return rowOf(kernel).name; }

std::optional<TraceKernel> kernelNamed(std::string_view name) {
  for (const KernelRow& row : kKernels)
    if (name == row.name) return row.kernel;
  return std::nullopt;
}

const std::vector<std::string>& kernelNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const KernelRow& row : kKernels) n.push_back(row.name);
    return n;
  }();
  return names;
}

std::vector<TraceKernel> machineKernels() {
  std::vector<TraceKernel> kernels = cpuKernels();
  if (const std::optional<TraceKernel> cap = configCap()) {
    const int top = rankOf(*cap);
    std::vector<TraceKernel> kept;
    for (TraceKernel k : kernels)
      if (rankOf(k) <= top) kept.push_back(k);
    if (!kept.empty()) kernels = std::move(kept);
  }
  return kernels;
}

TraceKernel machineBestKernel() { return machineKernels().back(); }

bool machineRuns(TraceKernel kernel, std::string* runs) {
  const std::vector<TraceKernel> kernels = machineKernels();
  if (runs) {
    runs->clear();
    for (TraceKernel k : kernels) *runs += std::string(runs->empty() ? "" : ", ") + kernelName(k);
  }
  return std::find(kernels.begin(), kernels.end(), kernel) != kernels.end();
}

std::string embreeDeviceConfig(TraceKernel kernel) {
  std::string config;
  for (const std::string& s : configSettings())
    if (!isIsaSetting(s)) config += s + ",";
  return config + "isa=" + rowOf(kernel).embreeIsa;
}

std::string commonKernel(const std::vector<std::vector<std::string>>& workers, const std::vector<std::string>& first) {
  const auto widest = [](const std::vector<std::string>& names, const auto& keep) {
    std::optional<TraceKernel> best;
    for (const std::string& n : names)
      if (const auto k = kernelNamed(n); k && keep(*k) && (!best || rankOf(*k) > rankOf(*best))) best = k;
    return best;
  };
  const auto everyoneRuns = [&](TraceKernel k) {
    for (const std::vector<std::string>& w : workers)
      if (!runsKernel(w, kernelName(k))) return false;
    return true;
  };
  // A worker that said nothing (an outside client) is pinned to what the others run.
  std::vector<std::string> candidates = first;
  if (candidates.empty())
    for (const std::vector<std::string>& w : workers) candidates.insert(candidates.end(), w.begin(), w.end());
  if (const auto k = widest(candidates, everyoneRuns)) return kernelName(*k);
  if (const auto k = widest(candidates, [](TraceKernel) { return true; })) return kernelName(*k);
  return {};  // nobody said: each worker traces with its own best, as before kernels were pinned
}

bool runsKernel(const std::vector<std::string>& kernels, const std::string& kernel) {
  return kernel.empty() || kernels.empty() || std::find(kernels.begin(), kernels.end(), kernel) != kernels.end();
}

}  // namespace lensfarm
