#include "tests/support/local_slurm.h"

#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <fstream>
#include <stdexcept>
#include <thread>

namespace lensfarm::test {

namespace fs = std::filesystem;

namespace {

std::optional<fs::path> onPath(const std::string& name) {
  for (const char* dir : {"/usr/sbin", "/usr/bin", "/sbin", "/bin", "/usr/local/bin", "/usr/local/sbin"})
    if (::access((fs::path(dir) / name).c_str(), X_OK) == 0) return fs::path(dir) / name;
  return std::nullopt;
}

std::string userName() {
  const passwd* pw = ::getpwuid(::getuid());
  return pw ? pw->pw_name : "root";
}

}  // namespace

std::optional<std::string> LocalSlurm::unavailableReason() {
  for (const char* tool : {"munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel", "sinfo"})
    if (!onPath(tool))
      return std::string(tool) + " is not installed (Debian: slurm-wlm and munge; scripts/setup.sh test)";
  return std::nullopt;
}

LocalSlurm::LocalSlurm(const fs::path& dir) : dir_(dir), conf_(dir / "slurm.conf") {
  for (const char* sub : {"munge", "state", "spool", "log"}) fs::create_directories(dir_ / sub);
  fs::permissions(dir_ / "munge", fs::perms::owner_all, fs::perm_options::replace);

  // munge: a private key (owner read only, as munged demands) and a socket of its own.
  {
    std::ifstream random("/dev/urandom", std::ios::binary);
    std::string key(1024, '\0');
    random.read(key.data(), std::streamsize(key.size()));
    std::ofstream(dir_ / "munge/key", std::ios::binary) << key;
    fs::permissions(dir_ / "munge/key", fs::perms::owner_read, fs::perm_options::replace);
  }
  const fs::path socket = dir_ / "munge/socket";
  munged_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{
          *onPath("munged"), "--foreground", "--force", "--key-file=" + (dir_ / "munge/key").string(),
          "--socket=" + socket.string(), "--pid-file=" + (dir_ / "munge/pid").string(),
          "--log-file=" + (dir_ / "log/munged.log").string(), "--seed-file=" + (dir_ / "munge/seed").string()},
      dir_ / "log/munged");
  if (!waitFor([&] { return fs::exists(socket); }, 20))
    throw std::runtime_error("munged did not start: " + munged_->log() + readFile(dir_ / "log/munged.log"));

  const std::string user = userName();
  const unsigned cpus = std::max(1u, std::thread::hardware_concurrency());
  std::ofstream conf(conf_);
  conf << "ClusterName=lensfarmtest\n"
       << "SlurmctldHost=localhost(127.0.0.1)\n"
       << "SlurmctldPort=" << freePort() << "\nSlurmdPort=" << freePort() << "\n"
       << "SlurmUser=" << user << "\nSlurmdUser=" << user << "\n"
       << "AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket=" << socket.string() << "\n"
       << "StateSaveLocation=" << (dir_ / "state").string() << "\n"
       << "SlurmdSpoolDir=" << (dir_ / "spool").string() << "\n"
       << "SlurmctldPidFile=" << (dir_ / "slurmctld.pid").string() << "\n"
       << "SlurmdPidFile=" << (dir_ / "slurmd.pid").string() << "\n"
       << "SlurmctldLogFile=" << (dir_ / "log/slurmctld.log").string() << "\n"
       << "SlurmdLogFile=" << (dir_ / "log/slurmd.log").string() << "\n"
       << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nMpiDefault=none\n"
       << "SchedulerType=sched/builtin\nSelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\n"
       << "JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n"
       << "ReturnToService=2\nInactiveLimit=0\nKillWait=10\nMinJobAge=600\n"
       << "NodeName=localhost NodeAddr=127.0.0.1 CPUs=" << cpus << " State=UNKNOWN\n"
       << "PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4\n";
  conf.close();

  slurmctld_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{*onPath("slurmctld"), "-D", "-f", conf_.string()}, dir_ / "log/slurmctld");
  slurmd_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{*onPath("slurmd"), "-D", "-f", conf_.string(), "-N", "localhost"}, dir_ / "log/slurmd");
  const bool idle = waitFor(
      [&] {
        return run({"sinfo", "-h", "-o", "%T"}, 10).out.find("idle") != std::string::npos;
      },
      60);
  if (!idle) throw std::runtime_error("the Slurm node did not come up:\n" + logs());
}

LocalSlurm::~LocalSlurm() {
  // Every job cancelled and its processes gone before the daemons stop: slurmstepd outlives
  // slurmd, and a job left running would outlive the test.
  run({"scancel", "--user=" + userName()}, 20);
  waitFor([&] { return run({"squeue", "-h"}, 10).out.empty(); }, 60);
  for (auto* daemon : {&slurmd_, &slurmctld_, &munged_})
    if (*daemon) {
      (*daemon)->signal(SIGTERM);
      (*daemon)->wait(20);
    }
}

ProcessResult LocalSlurm::run(std::vector<std::string> argv, double timeoutSeconds) const {
  argv.insert(argv.begin(), {"/usr/bin/env", confVariable()});
  return runProcess(argv, timeoutSeconds);
}

std::vector<std::string> LocalSlurm::tasks(const std::string& jobId) const {
  std::vector<std::string> rows = lines(run({"squeue", "-h", "-r", "-j", jobId, "-o", "%i %T"}, 20).out);
  rows.erase(std::remove(rows.begin(), rows.end(), std::string()), rows.end());
  std::sort(rows.begin(), rows.end());
  return rows;
}

std::string LocalSlurm::logs() const {
  std::string text;
  for (const char* log : {"slurmctld.log", "slurmd.log", "munged.log", "slurmctld.stderr", "slurmd.stderr"})
    text += std::string("---- ") + log + "\n" + readFile(dir_ / "log" / log);
  return text;
}

}  // namespace lensfarm::test
