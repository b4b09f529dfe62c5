// The farm with its parts on different hosts: network namespaces joined by veth pairs to a
// bridge stand for a coordinator host, two worker hosts and a client host, each with its own
// address. The farm runs there with TLS and tokens; one worker's link is cut mid-job; the job
// still completes, and its image equals the single-process render bit for bit.
// Needs root (CAP_NET_ADMIN) and `ip netns`; fails otherwise, saying so (it never skips, so a
// green run always includes it).
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <regex>
#include <sstream>

#include "common/film/image_io.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::string ipCommand() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"})
    if (fs::exists(p)) return p;
  return "";
}

// `ip ARGS`; throws with ip's message on failure.
void ip(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {ipCommand()};
  argv.insert(argv.end(), args.begin(), args.end());
  const test::ProcessResult r = test::runProcess(argv, 30);
  if (r.exitCode != 0) {
    std::string line;
    for (const auto& a : argv) line += a + " ";
    throw std::runtime_error(line + ": " + r.err);
  }
}

// Hosts on one switch: a namespace per host with eth0 at its address, plugged by a veth pair into
// a bridge in a switch namespace. Every namespace is deleted on destruction (their processes
// must be gone first); namespaces left by an earlier run that died are deleted on construction.
class Lab {
 public:
  static constexpr const char* kPrefix = "lensfarm-mh-";

  Lab() : prefix_(kPrefix + std::to_string(::getpid()) + "-") {
    removeStale();
    try {
      add("sw");
      ip({"-n", ns("sw"), "link", "add", "br0", "type", "bridge"});
      ip({"-n", ns("sw"), "link", "set", "br0", "up"});
    } catch (...) {
      removeAll();  // no destructor runs for an object whose constructor threw
      throw;
    }
  }
  ~Lab() { removeAll(); }
  Lab(const Lab&) = delete;
  Lab& operator=(const Lab&) = delete;

  // A host `name` at `address` (/24) on the switch; the switch side of its cable is `name`.
  void addHost(const std::string& name, const std::string& address) {
    add(name);
    ip({"link", "add", "eth0", "netns", ns(name), "type", "veth", "peer", "name", name, "netns", ns("sw")});
    ip({"-n", ns("sw"), "link", "set", name, "master", "br0", "up"});
    ip({"-n", ns(name), "addr", "add", address + "/24", "dev", "eth0"});
    ip({"-n", ns(name), "link", "set", "eth0", "up"});
    ip({"-n", ns(name), "link", "set", "lo", "up"});
  }
  // Pulls the host's cable out of the switch.
  void cut(const std::string& name) { ip({"-n", ns("sw"), "link", "set", name, "down"}); }
  // The command prefix that runs a program on host `name`.
  std::vector<std::string> on(const std::string& name) const { return {ipCommand(), "netns", "exec", ns(name)}; }
  std::string ns(const std::string& name) const { return prefix_ + name; }

  // Whether namespaces can be made here; if not, why.
  // The one reason to skip: not root (then the test skips with a clear message). As
  // root, a missing `ip` (scripts/setup.sh installs iproute2) or a failing `ip netns add` is a
  // failure, never a silent skip.
  static bool isRoot() { return ::geteuid() == 0; }
  static std::optional<std::string> brokenAsRoot() {
    if (ipCommand().empty()) return "the ip command is missing (scripts/setup.sh installs iproute2)";
    const std::string probe = kPrefix + std::to_string(::getpid()) + "-probe";
    const auto added = test::runProcess({ipCommand(), "netns", "add", probe}, 30);
    if (added.exitCode != 0) return "`ip netns add` fails here: " + added.err;
    test::runProcess({ipCommand(), "netns", "delete", probe}, 30);
    return std::nullopt;
  }

 private:
  void add(const std::string& name) {
    ip({"netns", "add", ns(name)});
    namespaces_.push_back(ns(name));
  }
  void removeAll() {
    for (auto it = namespaces_.rbegin(); it != namespaces_.rend(); ++it)
      test::runProcess({ipCommand(), "netns", "delete", *it}, 30);
    namespaces_.clear();
  }
  // Deletes namespaces of this test whose process is gone.
  static void removeStale() {
    const auto list = test::runProcess({ipCommand(), "netns", "list"}, 30);
    const std::regex ours(std::string("^") + kPrefix + "([0-9]+)-\\S+");
    std::istringstream in(list.out);
    for (std::string line; std::getline(in, line);) {
      std::smatch m;
      if (!std::regex_search(line, m, ours)) continue;
      if (::kill(pid_t(std::stol(m[1])), 0) != 0 && errno == ESRCH)
        test::runProcess({ipCommand(), "netns", "delete", test::words(line)[0]}, 30);
    }
  }

  std::string prefix_;
  std::vector<std::string> namespaces_;
};

// Units done by the worker named `name`, as `lensfarm workers` shows them.
int unitsOf(const std::string& workersTable, const std::string& name) {
  std::smatch m;
  if (!std::regex_search(workersTable, m, std::regex("\\n\\S+\\s+" + name + R"(\s+[0-9]+\s+\S+\s+([0-9]+)\s)")))
    return -1;
  return std::stoi(m[1]);
}

TEST(MultiHost, AFarmAcrossHostsSurvivesACutLinkAndRendersTheSameBits) {
  // Network namespaces need root. Without it the test fails: a green run always means the farm
  // was tested across hosts.
  if (!Lab::isRoot())
    FAIL() << "the multi-host test needs root to create network namespaces; run the tests as root "
              "(make test does in CI)";
  if (const auto why = Lab::brokenAsRoot()) FAIL() << "multi-host test cannot run as root: " << *why;
  test::TempDir dir;
  const std::string coordinatorIp = "10.231.0.1";
  test::makeCertificates(dir, "IP:" + coordinatorIp);
  const std::string clientToken = dir.write("client.token", "multi-host-client-token\n").string();
  const std::string workerToken = dir.write("worker.token", "multi-host-worker-token\n").string();
  const fs::path scene = test::writeSeedScene(dir, 64, 3072, 256);  // 12 units of ~1M paths

  Lab lab;  // declared before the processes, so they die before their namespaces go
  lab.addHost("coord", coordinatorIp);
  lab.addHost("w1", "10.231.0.2");
  lab.addHost("w2", "10.231.0.3");
  lab.addHost("client", "10.231.0.4");

  test::FarmProcesses farm(dir);
  const std::string address = farm.startCoordinator(
      {"--listen", coordinatorIp + ":7878", "--metrics-listen", coordinatorIp + ":9464", "--client-token-file",
       clientToken, "--worker-token-file", workerToken, "--tls-cert", (dir / "server.pem").string(), "--tls-key",
       (dir / "server.key").string(), "--lease-timeout", "2", "--heartbeat-interval", "0.2"},
      lab.on("coord"));
  ASSERT_EQ(address, coordinatorIp + ":7878");
  const std::vector<std::string> tls = {"--tls-ca", (dir / "ca.pem").string()};
  const auto workerArgs = [&] {
    std::vector<std::string> a = {"--coordinator", address, "--token-file", workerToken, "--threads", "1"};
    a.insert(a.end(), tls.begin(), tls.end());
    return a;
  };
  test::ChildProcess& w1 = farm.startWorker("w1", workerArgs(), lab.on("w1"));
  farm.startWorker("w2", workerArgs(), lab.on("w2"));
  std::vector<std::string> client = {"--coordinator", address, "--token-file", clientToken};
  client.insert(client.end(), tls.begin(), tls.end());
  const auto fromClient = [&](std::vector<std::string> args) {
    args.insert(args.end(), client.begin(), client.end());
    return farm.cli(args, lab.on("client"));
  };

  // The client host cannot reach the coordinator without TLS, nor without its token.
  EXPECT_EQ(farm.cli({"status", "--coordinator", address, "--token-file", clientToken}, lab.on("client")).exitCode, 3);
  EXPECT_EQ(farm.cli({"status", "--coordinator", address, "--tls-ca", tls[1]}, lab.on("client")).exitCode, 6);

  std::vector<std::string> submit = {scene.string()};
  submit.insert(submit.end(), client.begin(), client.end());
  const std::string job = farm.submit(submit, lab.on("client"));
  ASSERT_EQ(job, "job-1");

  // Once w1 has delivered a unit (and holds the lease of its next one), pull its cable.
  ASSERT_TRUE(test::waitFor([&] { return unitsOf(fromClient({"workers"}).out, "w1") >= 1; }, 60))
      << fromClient({"workers"}).out << farm.coordinator().log();
  lab.cut("w1");

  const auto watched = fromClient({"watch", job});
  ASSERT_EQ(watched.exitCode, 0) << watched.err << farm.coordinator().log();
  const fs::path farmExr = dir / "farm.exr";
  const auto downloaded = fromClient({"download", job, "-o", farmExr.string()});
  ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;

  // The metrics, scraped from the client host: w1's lease lapsed and its unit was rendered again.
  const auto metrics = test::parseMetrics(test::httpGet(coordinatorIp + ":9464", "/metrics", lab.ns("client")));
  ASSERT_FALSE(metrics.empty()) << "metrics unreachable from the client host";
  EXPECT_EQ(metrics.at("lensfarm_jobs{state=\"done\"}"), 1.0);
  EXPECT_EQ(metrics.at("lensfarm_units_done_total"), 12.0);
  EXPECT_GE(metrics.at("lensfarm_units_expired_total"), 1.0) << "the cut worker's lease lapsed";
  // Audits (docs/farm.md "Audit") are leases too: each worker's first unit at least.
  EXPECT_EQ(metrics.at("lensfarm_audits_total{result=\"failed\"}"), 0.0);
  EXPECT_EQ(metrics.at("lensfarm_units_leased_total"),
            12.0 + metrics.at("lensfarm_units_expired_total") + metrics.at("lensfarm_audits_total{result=\"passed\"}"));
  EXPECT_TRUE(test::waitFor(
      [&] {
        const auto m = test::parseMetrics(test::httpGet(coordinatorIp + ":9464", "/metrics", lab.ns("client")));
        return m.count("lensfarm_workers_alive") && m.at("lensfarm_workers_alive") == 1.0;
      },
      30))
      << "only w2 is still heard from";
  EXPECT_TRUE(w1.running()) << "cut off, w1 waits for its network, it does not crash: " << w1.log();

  // The same bits as one process rendering the same scene.
  ImageMetadata farmMeta, localMeta;
  const Image farmImage = readExr(farmExr, &farmMeta);
  const fs::path localExr = dir / "local.exr";
  const auto rendered = test::runProcess(
      {test::cliPath().string(), "render", scene.string(), "-o", localExr.string(), "--threads", "2", "-q"}, 120);
  ASSERT_EQ(rendered.exitCode, 0) << rendered.err;
  const Image localImage = readExr(localExr, &localMeta);
  EXPECT_EQ(farmMeta.totalSamples, 64u * 64u * 3072u) << "every unit counted once";
  EXPECT_EQ(farmMeta.sceneHash, localMeta.sceneHash);
  ASSERT_EQ(farmImage.rgb.size(), localImage.rgb.size());
  EXPECT_TRUE(farmImage.rgb == localImage.rgb) << "the farm's image differs from the single-process render";
  EXPECT_NE(farmMeta.extra["workers"].find("w1: "), std::string::npos) << farmMeta.extra["workers"];
  EXPECT_NE(farmMeta.extra["workers"].find("w2: "), std::string::npos) << farmMeta.extra["workers"];
}

}  // namespace
}  // namespace lensfarm
