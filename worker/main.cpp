// lensfarm-worker: renders units leased from a coordinator on this machine's cores.
//
//   lensfarm-worker --coordinator farm-host:7878 [--threads N] [--name NAME] [--cache-dir DIR]
//
// Signals (docs/farm.md, "Stopping a worker"): SIGINT and SIGUSR1 drain (the unit in progress is
// finished and uploaded, then the worker leaves); SIGTERM drains too, or with --on-sigterm release
// gives its lease back at once (batch schedulers: Slurm's scancel, time limit and preemption send
// SIGTERM, then SIGKILL after KillWait). A second signal of any kind stops at once.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include "common/farm/job_policy.h"
#include "common/farm/memory_estimate.h"
#include "common/render/ray_caster.h"
#include "common/util/atomic_file.h"
#include "common/util/error.h"
#include "common/util/flag_checks.h"
#include "common/util/logging.h"
#include "common/util/secret.h"
#include "common/util/service_flags.h"
#include "common/util/version.h"
#include "worker/grpc_link.h"
#include "worker/worker_loop.h"

namespace {
// Signal handlers only count; a watcher thread turns the counts into stop requests.
std::atomic<int> gSignals{0};     // every stop signal
std::atomic<int> gTerminates{0};  // SIGTERM among them
extern "C" void onSignal(int sig) {
  if (sig == SIGTERM) gTerminates.fetch_add(1);
  gSignals.fetch_add(1);
}

std::string defaultName() {
  char host[256] = {0};
  ::gethostname(host, sizeof host - 1);
  return std::string(host) + "-" + std::to_string(::getpid());
}

std::string defaultCacheDir() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME")) return std::string(xdg) + "/lensfarm/assets";
  if (const char* home = std::getenv("HOME")) return std::string(home) + "/.cache/lensfarm/assets";
  return "";
}

using namespace lensfarm;

// Everything the command line sets.
struct Flags {
  std::string coordinator, logLevel = "info", cacheDir = defaultCacheDir(), tokenFile, onSigterm = "drain";
  WorkerOptions options;
  ChannelSecurity security;
};

void addFlags(CLI::App& app, Flags& f) {
  WorkerOptions& options = f.options;
  app.add_option("--coordinator", f.coordinator, "Coordinator address HOST:PORT")
      ->envname("LENSFARM_COORDINATOR")
      ->required();
  app.add_option("--threads", options.threads, "Render threads")
      ->envname("LENSFARM_THREADS")
      ->check(CLI::Range(1u, 4096u))
      ->capture_default_str();
  app.add_option("--name", options.name, "Name shown by `lensfarm workers`")->envname("LENSFARM_WORKER_NAME");
  app.add_option("--tags", options.tags,
                 "Its tags, comma-separated (e.g. studio-a,bigmem): jobs submitted --require TAGS render only on "
                 "workers with them")
      ->envname("LENSFARM_WORKER_TAGS")
      ->delimiter(',');
  app.add_option("--cache-dir", f.cacheDir, "Asset cache directory (empty: memory only)")
      ->envname("LENSFARM_CACHE_DIR")
      ->capture_default_str();
  app.add_option("--max-backoff", options.maxBackoffSeconds, "Longest wait between retries, seconds")
      ->envname("LENSFARM_MAX_BACKOFF")
      ->check(numberIn(0.1, 600.0, "seconds"))
      ->capture_default_str();
  app.add_option("--token-file", f.tokenFile, "File holding the farm's worker token (or set LENSFARM_TOKEN)");
  app.add_option("--tls-ca", f.security.caFile, "PEM CA certificate(s) to verify the coordinator: enables TLS")
      ->envname("LENSFARM_TLS_CA");
  app.add_option("--tls-cert", f.security.certFile, "PEM client certificate, for coordinators that require one")
      ->envname("LENSFARM_TLS_CERT");
  app.add_option("--tls-key", f.security.keyFile, "PEM private key of --tls-cert")->envname("LENSFARM_TLS_KEY");
  app.add_option("--on-sigterm", f.onSigterm,
                 "On SIGTERM: drain (finish and upload the unit in progress, then leave) or release (give its "
                 "lease back at once and leave; for batch schedulers that kill soon after SIGTERM)")
      ->envname("LENSFARM_ON_SIGTERM")
      ->check(CLI::IsMember({"drain", "release"}))
      ->capture_default_str();
  app.add_option("--idle-exit", options.idleExitSeconds,
                 "Leave the farm after this many seconds without a unit to render (0: never)")
      ->envname("LENSFARM_IDLE_EXIT")
      ->check(numberIn(0.0, 1e9, "seconds"))
      ->capture_default_str();
  addLogLevelOption(app, f.logLevel);
}

// Turns the signals into stop requests until `finished`: the first drains (finishes and uploads
// the current unit), or with --on-sigterm release gives the lease back at once on SIGTERM; a
// second stops at once. Either way the worker then leaves the farm, and the coordinator queues the
// units of its leases again at once.
void watchSignals(WorkerLoop& loop, bool releaseOnTerm, const std::atomic<bool>& finished) {
  int seen = 0;
  while (!finished) {
    const int n = gSignals.load();
    if (n > seen) {
      if (releaseOnTerm && gTerminates.load() > 0) {
        if (seen == 0) spdlog::info("SIGTERM: giving the current unit back and leaving");
        loop.stopNow();
      } else if (seen == 0) {
        spdlog::info("draining: finishing the current unit");
        loop.stop();
      }
      if (n >= 2) loop.stopNow();
      seen = n;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lensfarm-worker: renders units of lensfarm jobs for a coordinator"};
  app.set_version_flag("--version", kRendererVersion);
  app.footer(kEmbreeConfigHelp);
  Flags f;
  f.options.threads = std::max(1u, std::thread::hardware_concurrency());
  f.options.name = defaultName();
  addFlags(app, f);
  if (const auto exitCode = parseServiceFlags(app, argc, argv, "lensfarm-worker")) return *exitCode;
  WorkerOptions& options = f.options;
  setupLogging("worker " + options.name, f.logLevel);
  createFilesPrivately();  // cached scenes and assets are the farm's, not the machine's other users'
  options.cacheDir = f.cacheDir;
  if (!f.cacheDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(f.cacheDir, ec);
    if (ec) {
      std::cerr << "lensfarm-worker: error: --cache-dir " << f.cacheDir << ": " << ec.message() << "\n";
      return 2;
    }
    makePrivateDirectory(f.cacheDir, "--cache-dir");
    removeStaleTemporaries(f.cacheDir, true);  // writes a killed worker left
  }

  std::shared_ptr<grpc::Channel> channel;
  try {
    for (const std::string& tag : options.tags) {
      try {
        checkTag(tag, "--tags");
      } catch (const FarmError& e) {
        throw InputError("--tags", std::string(e.what()).substr(std::string("--tags: ").size()));
      }
    }
    f.security.token = readToken(f.tokenFile, "LENSFARM_TOKEN");
    options.maxMemoryBytes = defaultJobMemoryBudget();  // LENSFARM_MAX_JOB_MEMORY, else 3/4 of memory
    channel = makeChannel(f.coordinator, f.security, options.maxBackoffSeconds, /*keepalive=*/true);
  } catch (const InputError& e) {
    std::cerr << "lensfarm-worker: error: " << e.what() << "\n";
    return 2;
  }
  GrpcCoordinatorLink link(channel, f.security);
  WorkerLoop loop(link, options);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  std::signal(SIGUSR1, onSignal);
  std::atomic<bool> finished{false};
  std::thread watcher([&] { watchSignals(loop, f.onSigterm == "release", finished); });
  spdlog::info("working for {} with {} threads", f.coordinator, options.threads);
  int code = 0;
  try {
    loop.run();
  } catch (const FarmError& e) {
    spdlog::error("{}", e.what());
    code = 3;
  }
  finished = true;
  watcher.join();
  if (code) return code;
  spdlog::info("stopped after {} units ({} accepted)", loop.counters().unitsRendered.load(),
               loop.counters().unitsAccepted.load());
  return 0;
}
