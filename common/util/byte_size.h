#pragma once
// Sizes of memory: this machine's, the budget one job may use by default, and sizes as people
// write them ("16G", "512MiB") and read them ("31.7 GB").
#include <cstdint>
#include <string>

namespace lensfarm {

// This machine's memory: physical memory (sysconf), or the cgroup's limit (memory.max, v2; or
// memory.limit_in_bytes, v1) when that is lower.
uint64_t machineMemoryBytes();

// The memory one job may use: LENSFARM_MAX_JOB_MEMORY if set (parseByteSize; InputError naming it
// if malformed), else 3/4 of machineMemoryBytes().
uint64_t defaultJobMemoryBudget();
// Where the budget comes from, for messages: "LENSFARM_MAX_JOB_MEMORY" or "3/4 of 23.3 GB of memory".
std::string defaultJobMemoryBudgetSource();

// "16G", "512MiB", "1.5GB", "2000000000": K, M, G, T (with or without "iB") are powers of 1024;
// KB, MB, GB, TB powers of 1000; no suffix is bytes. Nothing, zero or garbage gives 0.
uint64_t parseByteSize(const std::string& text);

// "31.7 GB", "830 MB", "12 kB" (decimal units).
std::string formatBytes(uint64_t bytes);

}  // namespace lensfarm
