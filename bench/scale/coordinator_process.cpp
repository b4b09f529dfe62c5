#include "bench/scale/coordinator_process.h"

#include <fcntl.h>
#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace lensfarm::scale {
namespace fs = std::filesystem;
namespace {

std::string slurp(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  text.erase(text.find_last_not_of("\n") + 1);
  return text;
}

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text << "\n";
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);  // a token file must be
}

// A field "Name:   123 kB" of /proc/<pid>/status, in bytes.
uint64_t statusBytes(pid_t pid, const std::string& name) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind(name + ":", 0) == 0) return std::stoull(line.substr(name.size() + 1)) * 1024;
  return 0;
}

}  // namespace

CoordinatorProcess::CoordinatorProcess(const fs::path& binary, const std::vector<std::string>& extraArgs) {
  std::string pattern = (fs::temp_directory_path() / "lensfarm-scale-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temp dir under " + pattern);
  dir_ = pattern;
  clientToken_ = "scale-client-" + std::to_string(::getpid());
  workerToken_ = "scale-worker-" + std::to_string(::getpid());
  writeText(dir_ / "client.token", clientToken_);
  writeText(dir_ / "worker.token", workerToken_);
  std::vector<std::string> argv = {binary.string(),
                                   "--listen",
                                   "127.0.0.1:0",
                                   "--port-file",
                                   (dir_ / "port").string(),
                                   "--metrics-listen",
                                   "127.0.0.1:0",
                                   "--metrics-port-file",
                                   (dir_ / "metrics-port").string(),
                                   "--state-dir",
                                   (dir_ / "state").string(),
                                   "--client-token-file",
                                   (dir_ / "client.token").string(),
                                   "--worker-token-file",
                                   (dir_ / "worker.token").string()};
  argv.insert(argv.end(), extraArgs.begin(), extraArgs.end());
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, 1, (dir_ / "stdout").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&files, 2, (dir_ / "stderr").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int failed = posix_spawn(&pid_, args[0], &files, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  if (failed != 0) {
    fs::remove_all(dir_);
    throw std::runtime_error("cannot start " + binary.string());
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!(fs::exists(dir_ / "port") && fs::exists(dir_ / "metrics-port"))) {
    if (!running() || std::chrono::steady_clock::now() > deadline) {
      const std::string why = log();
      stop();
      throw std::runtime_error("the coordinator did not start: " + why);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the files are written whole by now
  address_ = slurp(dir_ / "port");
  metricsAddress_ = slurp(dir_ / "metrics-port");
}

CoordinatorProcess::~CoordinatorProcess() { stop(); }

void CoordinatorProcess::stop() {
  if (pid_ > 0 && !reaped_) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    reaped_ = true;
  }
  std::error_code ignored;
  if (!dir_.empty() && !keep_) fs::remove_all(dir_, ignored);
  dir_.clear();
}

bool CoordinatorProcess::running() {
  if (!reaped_ && ::waitpid(pid_, nullptr, WNOHANG) == pid_) reaped_ = true;
  return !reaped_;
}

double CoordinatorProcess::cpuSeconds() const {
  // /proc/<pid>/stat: the command (field 2) is in parentheses and may hold
  // spaces; utime and stime are fields 14 and 15, i.e. the 12th and 13th after
  // the closing parenthesis.
  const std::string stat = slurp("/proc/" + std::to_string(pid_) + "/stat");
  std::istringstream rest(stat.substr(stat.rfind(')') + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stoull(field);
    if (i == 15) stime = std::stoull(field);
  }
  return double(utime + stime) / double(::sysconf(_SC_CLK_TCK));
}

uint64_t CoordinatorProcess::residentBytes() const { return statusBytes(pid_, "VmRSS"); }
uint64_t CoordinatorProcess::peakResidentBytes() const { return statusBytes(pid_, "VmHWM"); }

std::map<std::string, double> CoordinatorProcess::metrics() const {
  const size_t colon = metricsAddress_.rfind(':');
  httplib::Client http(metricsAddress_.substr(0, colon), std::stoi(metricsAddress_.substr(colon + 1)));
  http.set_read_timeout(30, 0);
  const auto response = http.Get("/metrics");
  if (!response || response->status != 200)
    throw std::runtime_error("GET http://" + metricsAddress_ + "/metrics failed");
  std::map<std::string, double> samples;
  std::istringstream lines(response->body);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.rfind(' ');
    if (space != std::string::npos) samples[line.substr(0, space)] = std::strtod(line.c_str() + space + 1, nullptr);
  }
  return samples;
}

std::string CoordinatorProcess::log() const { return slurp(dir_ / "stderr"); }

}  // namespace lensfarm::scale
