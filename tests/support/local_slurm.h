#pragma once
// A real Slurm on this machine for a test: munged with a private key and socket, slurmctld and
// slurmd (Debian's slurm-wlm) started in a temp dir from a generated slurm.conf, on free ports,
// with one node of this machine's CPUs. Everything runs as the current user (root or not: slurmd
// then only starts that user's jobs). Stopping cancels every job, waits for its processes to end,
// then stops the daemons.
//
// Known to work without cgroups or systemd: ProctrackType=proctrack/linuxproc, TaskPlugin=task/none,
// no accounting. The partition lets 4 jobs share a CPU (OverSubscribe=FORCE:4), so a 3-task array
// runs at once on a 2-core machine.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace lensfarm::test {

class LocalSlurm {
 public:
  // Why Slurm cannot run here (a binary missing), or nullopt.
  static std::optional<std::string> unavailableReason();

  explicit LocalSlurm(const std::filesystem::path& dir);  // starts the daemons; throws if they fail
  ~LocalSlurm();
  LocalSlurm(const LocalSlurm&) = delete;
  LocalSlurm& operator=(const LocalSlurm&) = delete;

  // Runs a Slurm client command (sbatch, squeue, scancel, ...) against this cluster.
  ProcessResult run(std::vector<std::string> argv, double timeoutSeconds = 60.0) const;
  // The environment variable that points Slurm's commands at this cluster.
  std::string confVariable() const { return "SLURM_CONF=" + conf_.string(); }
  // "ID STATE" per task of the job (squeue -r), sorted; empty when it has left the queue.
  std::vector<std::string> tasks(const std::string& jobId) const;
  // The daemons' logs, for a failure message.
  std::string logs() const;

 private:
  std::filesystem::path dir_, conf_;
  std::unique_ptr<ChildProcess> munged_, slurmctld_, slurmd_;
};

}  // namespace lensfarm::test
