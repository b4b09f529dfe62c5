#pragma once
// A lensfarm worker array on Slurm: what `lensfarm slurm` hands to sbatch and scancel
// (deploy/slurm/README.md). Plain data and pure functions; slurm_command.cpp runs them.
//
// One array task is one lensfarm-worker on --cpus-per-task cores (deploy/slurm/lensfarm-worker.sbatch);
// the settings reach the script as environment variables that sbatch passes on (--export=ALL),
// never inside sbatch's own arguments, so no value is split at a comma.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace lensfarm::cli {

struct SlurmArray {
  uint32_t workers = 1;      // array tasks: --array=0-(workers-1)
  uint32_t maxRunning = 0;   // at most this many at once (--array=...%K); 0: no limit
  uint32_t cpusPerTask = 4;  // each worker's --threads
  std::string jobName = "lensfarm-worker";
  std::string timeLimit;  // --time, in Slurm's forms (MM, HH:MM:SS, D-HH, ...); empty: the partition's
  std::string partition, account, qos;
  std::filesystem::path logDir;              // worker logs: <logDir>/lensfarm-worker-<array>_<task>.log
  std::filesystem::path script;              // lensfarm-worker.sbatch
  std::vector<std::string> extraSbatchArgs;  // passed to sbatch as they are, before the script

  // What the script reads (its header lists them).
  std::string coordinator;                // LENSFARM_COORDINATOR
  std::filesystem::path workerTokenFile;  // LENSFARM_TOKEN_FILE; empty: none (or LENSFARM_TOKEN)
  std::string workerBinary;               // LENSFARM_WORKER; empty: lensfarm-worker on the nodes' PATH
  double idleExitSeconds = 300.0;         // LENSFARM_IDLE_EXIT
};

// The sbatch command line: `sbatch --parsable --array=... ... SCRIPT`.
std::vector<std::string> sbatchArguments(const SlurmArray& array);

// The variables the script reads, for sbatch's environment.
std::map<std::string, std::string> workerEnvironment(const SlurmArray& array);

// The job id in `sbatch --parsable` output ("1234" or "1234;cluster"); InputError otherwise.
std::string parseSbatchJobId(const std::string& output);

// The command that lists the array's tasks still queued (one line each; none once all have ended).
std::vector<std::string> squeueArguments(const std::string& arrayJobId);

// The command that ends every task of the array (running ones get SIGTERM, pending ones never start).
std::vector<std::string> scancelArguments(const std::string& arrayJobId);

// True for an address workers on other machines cannot dial (127.0.0.0/8, localhost, ::1, 0.0.0.0).
bool isLocalOnlyAddress(const std::string& hostPort);

}  // namespace lensfarm::cli
