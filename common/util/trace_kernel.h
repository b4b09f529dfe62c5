#pragma once
// Embree's traversal kernels, by the bits they give: the farm's unit of "same machine".
//
// Embree 3 picks a kernel for the widest vector unit a machine has (its device configuration's
// `isa=`), and the kernels round ray-triangle tests differently: the same job differs by up to
// 1.4e-4 relative in a cell between them. Measured on cornell-classic, textured-spheres and
// cornell-glass-metal (docs/performance.md "What each Embree kernel costs"), the kernels fall
// into three classes of identical bits on x86-64 — `sse2` (Embree's sse2, sse4.2 and avx), `avx2`
// and `avx512` — and a job renders every unit with one class (docs/farm.md "Mixed machines"), so
// its image is the same bits whichever machine rendered what. An ARM machine runs Embree's NEON
// port, a class of its own (`neon`).
//
// A kernel is named by its class: "sse2", "avx2", "avx512", "neon". No Embree here: the
// coordinator ranks kernels without linking the tracer.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lensfarm {

enum class TraceKernel { kSse2, kAvx2, kAvx512, kNeon };

const char* kernelName(TraceKernel kernel);
std::optional<TraceKernel> kernelNamed(std::string_view name);
// Every class's name, narrowest first ("sse2, avx2, avx512, neon" for a message).
const std::vector<std::string>& kernelNames();

// The kernels this machine can run, narrowest first: those its CPU (and operating system) support,
// capped by an `isa=` in LENSFARM_EMBREE_CONFIG (an expert's override: "isa=avx2" keeps an
// AVX-512 machine to sse2 and avx2). Never empty.
std::vector<TraceKernel> machineKernels();
// The widest of machineKernels(): what `lensfarm render` and a job without a kernel use.
TraceKernel machineBestKernel();
// Whether `kernel` is one of machineKernels(); `runs` (if given) receives them as "sse2, avx2".
bool machineRuns(TraceKernel kernel, std::string* runs = nullptr);

// The Embree device configuration that selects `kernel`: LENSFARM_EMBREE_CONFIG's other settings
// (threads, verbose, ...) with its `isa=` replaced by the kernel's.
std::string embreeDeviceConfig(TraceKernel kernel);

// The kernel a job pins when its first unit is leased (docs/farm.md "Mixed machines"): the widest
// that every one of `workers` runs (each a list of kernel names as a worker reported them; an
// empty list, from a worker that did not say, constrains nothing) and `first` (the worker being
// leased the unit) runs; when they share none, the widest of `first`'s. Names that are not kernels
// are ignored; empty when no worker named one.
std::string commonKernel(const std::vector<std::vector<std::string>>& workers, const std::vector<std::string>& first);

// Whether a worker that reported `kernels` may render units of a job pinned to `kernel` (empty:
// not pinned yet). A worker that reported none is trusted to run any (an outside client).
bool runsKernel(const std::vector<std::string>& kernels, const std::string& kernel);

}  // namespace lensfarm
