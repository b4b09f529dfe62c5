#pragma once
// Runs another program (sbatch, scancel) and waits for it: its standard output captured, its
// standard error passed through to ours, so the user sees the program's own error message.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lensfarm::cli {

struct CommandResult {
  bool started = false;  // false: not found on PATH or not executable (`error` says why)
  int exitCode = -1;     // the exit status; 128 + N when killed by signal N
  std::string out;       // standard output
  std::string error;
};

// Runs argv[0] (searched on PATH) with argv, in this environment plus `extraEnvironment`
// (overriding variables of the same name).
CommandResult runCommand(const std::vector<std::string>& argv,
                         const std::map<std::string, std::string>& extraEnvironment = {});

// The directory of the running `lensfarm` binary (bin/ when installed, build/client/ when built),
// where it finds what was installed or built beside it; empty if /proc cannot say.
std::filesystem::path executableDir();

}  // namespace lensfarm::cli
