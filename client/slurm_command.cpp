// `lensfarm slurm`: starts workers as a Slurm job array from a login node, and, given jobs, waits
// until they end and cancels the array (deploy/slurm/README.md, docs/cli.md "slurm").
//
//   lensfarm slurm --workers 50 --cpus-per-task 8 --time 4:00:00 --partition gpu JOB
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <thread>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/farm_client.h"
#include "client/farm_connection.h"
#include "client/progress_display.h"
#include "client/slurm_array.h"
#include "client/subprocess.h"
#include "common/util/error.h"
#include "common/util/flag_checks.h"
#include "common/util/secret.h"

namespace lensfarm::cli {

namespace fs = std::filesystem;

namespace {

std::atomic<int> gStopSignal{0};
extern "C" void onStopSignal(int sig) { gStopSignal = sig; }

// lensfarm-worker.sbatch: installed beside the binaries (<prefix>/share/lensfarm/slurm), else in
// the source tree this binary was built from.
fs::path defaultWorkerScript() {
  for (const fs::path& candidate : {executableDir() / "../share/lensfarm/slurm/lensfarm-worker.sbatch",
                                    fs::path(LENSFARM_SOURCE_DIR) / "deploy/slurm/lensfarm-worker.sbatch"})
    if (fs::is_regular_file(candidate)) return fs::weakly_canonical(candidate);
  return {};
}

// The lensfarm-worker installed beside this binary (bin/), or built beside it (build/worker/);
// empty: the one on the compute nodes' PATH.
std::string defaultWorkerBinary() {
  for (const fs::path& candidate : {executableDir() / "lensfarm-worker", executableDir() / "../worker/lensfarm-worker"})
    if (::access(candidate.c_str(), X_OK) == 0) return fs::weakly_canonical(candidate).string();
  return "";
}

bool ended(v1::JobState s) {
  return s == v1::JOB_STATE_DONE || s == v1::JOB_STATE_CANCELLED || s == v1::JOB_STATE_FAILED;
}

// Whether the array still has tasks in Slurm's queue (pending, running or completing); nullopt when
// squeue cannot say (not on PATH, the controller busy).
std::optional<bool> arrayQueued(const std::string& arrayId) {
  const CommandResult r = runCommand(squeueArguments(arrayId));
  if (!r.started || r.exitCode != 0) return std::nullopt;
  return r.out.find_first_not_of(" \n") != std::string::npos;
}

// scancel of the whole array; says what it did.
void cancelArray(const std::string& arrayId, const std::string& why) {
  const CommandResult r = runCommand(scancelArguments(arrayId));
  if (r.started && r.exitCode == 0)
    std::fprintf(stderr, "cancelled Slurm job %s (%s)\n", arrayId.c_str(), why.c_str());
  else
    std::fprintf(stderr, "lensfarm: warning: scancel %s failed (%s); cancel it by hand\n", arrayId.c_str(),
                 r.started ? ("exit " + std::to_string(r.exitCode)).c_str() : r.error.c_str());
}

struct SlurmFlags {
  Connection c;
  SlurmArray array;
  std::vector<std::string> jobs;
};

// What the array's tasks are given, settled on the login node: the coordinator, the sbatch script,
// the worker binary, the log directory (made) and the worker token file (read). kOk, or
// kBadInput with the error printed.
int prepareArray(SlurmFlags& f) {
  SlurmArray& array = f.array;
  array.coordinator = f.c.coordinator;
  if (array.script.empty()) array.script = defaultWorkerScript();
  if (array.script.empty() || !fs::is_regular_file(array.script)) {
    std::fprintf(stderr, "lensfarm: error: --script %s: no lensfarm-worker.sbatch there\n", array.script.c_str());
    return kBadInput;
  }
  if (array.workerBinary.empty()) array.workerBinary = defaultWorkerBinary();
  std::error_code ec;
  array.logDir = fs::absolute(array.logDir.empty() ? fs::current_path() : array.logDir);
  fs::create_directories(array.logDir, ec);
  if (ec) {
    std::fprintf(stderr, "lensfarm: error: --log-dir %s: %s\n", array.logDir.c_str(), ec.message().c_str());
    return kBadInput;
  }
  if (!array.workerTokenFile.empty()) {
    // Read here, on the login node: a wrong path fails now, not on 50 compute nodes.
    array.workerTokenFile = fs::absolute(array.workerTokenFile);
    readToken(array.workerTokenFile.string(), "");
  }
  if (isLocalOnlyAddress(array.coordinator))
    std::fprintf(stderr,
                 "lensfarm: warning: workers will dial %s, which only reaches this machine; give --coordinator an "
                 "address the compute nodes can reach\n",
                 array.coordinator.c_str());
  return kOk;
}

// The jobs that have not ended yet, in the order given (each that has is named on stderr); a job
// that does not exist throws NOT_FOUND.
std::vector<std::string> openJobs(FarmClient& client, const std::vector<std::string>& jobs) {
  std::vector<std::string> open;
  for (const std::string& job : jobs) {
    const v1::JobStatus s = client.get(job);
    if (ended(s.state()))
      std::fprintf(stderr, "%s already %s\n", job.c_str(), stateName(s.state()));
    else
      open.push_back(job);
  }
  return open;
}

// sbatch of the worker array; its job id into `arrayId`, printed on stdout. kOk, or the exit code
// with the error printed (kBadInput: no sbatch here; kFailure: sbatch refused).
int submitArray(const SlurmArray& array, std::string& arrayId) {
  const CommandResult submitted = runCommand(sbatchArguments(array), workerEnvironment(array));
  if (!submitted.started) {
    std::fprintf(stderr, "lensfarm: error: %s (run this on a Slurm login node)\n", submitted.error.c_str());
    return kBadInput;
  }
  if (submitted.exitCode != 0) {
    std::fprintf(stderr, "lensfarm: error: sbatch refused the worker array (exit %d)\n", submitted.exitCode);
    return kFailure;
  }
  arrayId = parseSbatchJobId(submitted.out);
  std::printf("%s\n", arrayId.c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "submitted %u workers as Slurm job %s (squeue -r -j %s; logs in %s)\n", array.workers,
               arrayId.c_str(), arrayId.c_str(), array.logDir.c_str());
  return kOk;
}

// Waits for the jobs, then gives the allocation back. Ctrl-C (or a SIGTERM to this command)
// cancels the array too: no worker outlives the command that started it for them. Gives up
// (kJobNotDone) when every task of the array has left Slurm's queue with work left.
int waitThenCancel(FarmClient& client, const SlurmFlags& f, std::vector<std::string> open, const std::string& arrayId) {
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  bool allDone = true, warned = false;
  auto lastQueueCheck = std::chrono::steady_clock::now();
  while (!open.empty() && gStopSignal == 0) {
    // Every task gone (time limit, preemption, scancel by hand, a node failure) with work left:
    // waiting on would be waiting forever.
    if (std::chrono::steady_clock::now() - lastQueueCheck >= std::chrono::seconds(5)) {
      lastQueueCheck = std::chrono::steady_clock::now();
      if (arrayQueued(arrayId) == false) {
        std::fprintf(stderr,
                     "lensfarm: error: every worker of Slurm job %s has ended (time limit, preemption or "
                     "scancel; their logs are in %s) before %s ended; start more with lensfarm slurm\n",
                     arrayId.c_str(), f.array.logDir.c_str(), open.front().c_str());
        return kJobNotDone;
      }
    }
    try {
      const v1::JobStatus s = client.get(open.front());
      warned = false;
      if (ended(s.state())) {
        std::fprintf(stderr, "%s %s\n", s.job_id().c_str(), stateName(s.state()));
        allDone = allDone && s.state() == v1::JOB_STATE_DONE;
        open.erase(open.begin());
        continue;
      }
    } catch (const ClientError& e) {
      if (e.code() == grpc::StatusCode::NOT_FOUND) {  // deleted meanwhile
        std::fprintf(stderr, "%s: %s\n", open.front().c_str(), e.what());
        allDone = false;
        open.erase(open.begin());
        continue;
      }
      if (e.code() != grpc::StatusCode::UNAVAILABLE && e.code() != grpc::StatusCode::DEADLINE_EXCEEDED) throw;
      if (!warned) std::fprintf(stderr, "lensfarm: warning: %s; still waiting\n", e.what());
      warned = true;
    }
    for (int i = 0; i < 10 && gStopSignal == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (gStopSignal != 0) {
    cancelArray(arrayId, "interrupted");
    return kInterrupted;
  }
  cancelArray(arrayId, f.jobs.size() == 1 ? f.jobs[0] + " ended" : "the jobs ended");
  return allDone ? kOk : kJobNotDone;
}

// The command's run: the flags settled, the jobs checked, the array submitted and, given jobs,
// waited for.
int runSlurm(SlurmFlags& f) {
  if (const int code = prepareArray(f); code != kOk) return code;
  return guardedCall([&] {
    FarmClient client(f.c.coordinator, f.c.resolved());
    // The jobs exist (NOT_FOUND otherwise) before any allocation is asked for.
    const std::vector<std::string> open = openJobs(client, f.jobs);
    if (!f.jobs.empty() && open.empty()) return kOk;
    std::string arrayId;
    if (const int code = submitArray(f.array, arrayId); code != kOk) return code;
    if (open.empty()) return kOk;
    return waitThenCancel(client, f, open, arrayId);
  });
}

}  // namespace

Runner addSlurmCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "slurm", "Start workers as a Slurm job array; given jobs, wait until they end, then cancel the array");
  auto f = std::make_shared<SlurmFlags>();
  addCoordinatorOption(cmd, f->c);
  cmd->add_option("jobs", f->jobs,
                  "Jobs to work for: wait until they end, then scancel the workers (default: start "
                  "the workers and return; they leave after --idle-exit without work)");
  cmd->add_option("-n,--workers", f->array.workers, "Workers: one Slurm array task each")
      ->required()
      ->check(CLI::Range(1u, 1000000u));
  cmd->add_option("-c,--cpus-per-task", f->array.cpusPerTask, "Cores per worker (its --threads)")
      ->check(CLI::Range(1u, 4096u))
      ->capture_default_str();
  cmd->add_option("--max-running", f->array.maxRunning, "Run at most this many workers at once (0: as Slurm allows)");
  cmd->add_option("-t,--time", f->array.timeLimit, "Time limit of each worker, as sbatch --time takes it");
  cmd->add_option("-p,--partition", f->array.partition, "Slurm partition")->envname("SBATCH_PARTITION");
  cmd->add_option("-A,--account", f->array.account, "Slurm account to charge")->envname("SBATCH_ACCOUNT");
  cmd->add_option("-q,--qos", f->array.qos, "Slurm quality of service")->envname("SBATCH_QOS");
  cmd->add_option("--job-name", f->array.jobName, "Name of the Slurm job array")->capture_default_str();
  cmd->add_option("--log-dir", f->array.logDir, "Where the workers' logs go (lensfarm-worker-ARRAY_TASK.log)")
      ->default_str("the current directory");
  cmd->add_option("--worker-token-file", f->array.workerTokenFile,
                  "The farm's worker token, in a file the compute nodes can read (mode 600)");
  cmd->add_option("--worker-binary", f->array.workerBinary,
                  "lensfarm-worker on the compute nodes (default: the one beside this binary, else on their PATH)")
      ->envname("LENSFARM_WORKER");
  cmd->add_option("--idle-exit", f->array.idleExitSeconds, "A worker leaves after this many seconds without work")
      ->check(numberIn(0.0, 1e9, "seconds"))
      ->capture_default_str();
  cmd->add_option("--script", f->array.script, "The sbatch script (default: the installed lensfarm-worker.sbatch)")
      ->envname("LENSFARM_SLURM_SCRIPT");
  cmd->add_option("--sbatch-arg", f->array.extraSbatchArgs,
                  "One more sbatch argument (repeatable), e.g. --sbatch-arg=--mem=8G");
  return [f] { return runSlurm(*f); };
}

}  // namespace lensfarm::cli
