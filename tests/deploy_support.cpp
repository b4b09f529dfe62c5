#include "tests/deploy_support.h"

#include <fcntl.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

namespace lensfarm::test {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

Help helpOf(const fs::path& binary) {
  const ProcessResult r = runProcess({binary.string(), "--help"}, 30);
  EXPECT_EQ(r.exitCode, 0) << binary << " --help: " << r.err;
  Help help;
  help.text = r.out;
  // CLI11 lists each option at the start of a line, indented by two: "  -h,--help", "  --listen TEXT".
  const std::regex option(R"(^  (?:-\w,)?(--[a-z0-9][a-z0-9-]*))");
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, option)) help.flags.insert(m[1]);
  }
  return help;
}

std::multimap<std::string, std::string> optionsOf(const std::vector<std::string>& argv) {
  std::multimap<std::string, std::string> out;
  for (size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.rfind("--", 0) != 0) continue;
    if (const size_t eq = a.find('='); eq != std::string::npos) {
      out.emplace(a.substr(0, eq), a.substr(eq + 1));
    } else if (i + 1 < argv.size() && argv[i + 1].rfind("--", 0) != 0) {
      out.emplace(a, argv[++i]);
    } else {
      out.emplace(a, "");
    }
  }
  return out;
}

::testing::AssertionResult runsWithItsFlags(const std::vector<std::string>& argv, const fs::path& binary) {
  if (argv.empty() || (argv[0] != binary.string() && argv[0] != binary.filename().string()))
    return ::testing::AssertionFailure() << "does not run " << binary;
  const Help help = helpOf(binary);
  for (const auto& [flag, value] : optionsOf(argv))
    if (!help.flags.count(flag)) return ::testing::AssertionFailure() << flag << " is not a flag of " << binary;
  return ::testing::AssertionSuccess();
}

std::string optionOf(const std::vector<std::string>& argv, const std::string& flag) {
  const auto options = optionsOf(argv);
  const auto it = options.find(flag);
  return it == options.end() ? "" : it->second;
}

int portOf(const std::string& address) {
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos || colon + 1 == address.size()) return -1;
  const std::string digits = address.substr(colon + 1);
  if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; })) return -1;
  return std::stoi(digits);
}

std::string lineOf(const std::string& table, const std::string& name) {
  std::istringstream in(table);
  for (std::string line; std::getline(in, line);)
    if (line.find(" " + name + " ") != std::string::npos) return line;
  return "";
}

fs::path writeSeedScene(const TempDir& dir, int size, uint64_t spp, uint32_t perUnit) {
  json scene = json::parse(std::ifstream(scenesDir() / "cornell-seed.json"));
  scene["render"]["resolution"] = {size, size};
  scene["render"]["samples_per_pixel"] = spp;
  scene["render"]["samples_per_unit"] = perUnit;
  dir.write("meshes/cornell-box.obj", readFile(scenesDir() / "meshes/cornell-box.obj"));
  return dir.write("scene.json", scene.dump(2));
}

namespace {
std::vector<std::string> wrapped(const std::vector<std::string>& wrapper, const fs::path& program,
                                 const std::vector<std::string>& args) {
  std::vector<std::string> argv = wrapper;
  argv.push_back(program.string());
  argv.insert(argv.end(), args.begin(), args.end());
  return argv;
}

std::string firstLine(const std::string& text) { return text.substr(0, text.find('\n')); }
}  // namespace

std::string FarmProcesses::startCoordinator(std::vector<std::string> args, const std::vector<std::string>& wrapper) {
  const std::string n = std::to_string(++started_);
  const fs::path portFile = dir_ / ("port-" + n), metricsFile = dir_ / ("metrics-port-" + n),
                 dashboardFile = dir_ / ("dashboard-port-" + n);
  const bool metrics = optionsOf(args).count("--metrics-listen") > 0;
  const bool dashboard = optionsOf(args).count("--dashboard-listen") > 0;
  args.insert(args.end(), {"--port-file", portFile.string()});
  if (metrics) args.insert(args.end(), {"--metrics-port-file", metricsFile.string()});
  if (dashboard) args.insert(args.end(), {"--dashboard-port-file", dashboardFile.string()});
  coordinator_ = std::make_unique<ChildProcess>(wrapped(wrapper, coordinatorPath(), args), dir_ / ("coordinator-" + n));
  const bool up = waitFor(
      [&] {
        return (fs::exists(portFile) && (!metrics || fs::exists(metricsFile)) &&
                (!dashboard || fs::exists(dashboardFile))) ||
               !coordinator_->running();
      },
      30);
  if (!up || !fs::exists(portFile)) throw std::runtime_error("the coordinator did not start: " + coordinator_->log());
  if (metrics) metricsAddress_ = firstLine(readFile(metricsFile));
  if (dashboard) dashboardAddress_ = firstLine(readFile(dashboardFile));
  return firstLine(readFile(portFile));
}

ChildProcess& FarmProcesses::startWorker(const std::string& name, std::vector<std::string> args,
                                         const std::vector<std::string>& wrapper) {
  const bool backoffGiven = optionsOf(args).count("--max-backoff") > 0;
  args.insert(args.end(), {"--name", name, "--cache-dir", (dir_ / ("cache-" + name)).string()});
  if (!backoffGiven) args.insert(args.end(), {"--max-backoff", "0.3"});
  workers_.push_back(std::make_unique<ChildProcess>(wrapped(wrapper, workerPath(), args), dir_ / ("worker-" + name)));
  return *workers_.back();
}

ProcessResult FarmProcesses::cli(std::vector<std::string> args, const std::vector<std::string>& wrapper) const {
  return runProcess(wrapped(wrapper, cliPath(), args), 120);
}

std::string FarmProcesses::submit(std::vector<std::string> args, const std::vector<std::string>& wrapper) const {
  args.insert(args.begin(), "submit");
  const ProcessResult r = cli(args, wrapper);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  return firstLine(r.out);
}

std::map<std::string, double> parseMetrics(const std::string& text) {
  std::map<std::string, double> samples;
  std::set<std::string> helped;
  std::map<std::string, std::string> types;
  const std::regex help(R"(^# HELP ([a-zA-Z_:][a-zA-Z0-9_:]*) \S.*$)");
  const std::regex type(R"(^# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|histogram|summary|untyped)$)");
  const std::regex sample(
      R"(^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[a-zA-Z_][a-zA-Z0-9_]*="[^"\\]*"(?:,[a-zA-Z_][a-zA-Z0-9_]*="[^"\\]*")*\})? (\S+)$)");
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_match(line, m, help)) {
      EXPECT_TRUE(helped.insert(m[1]).second) << "two HELP lines for " << m[1];
    } else if (std::regex_match(line, m, type)) {
      EXPECT_TRUE(helped.count(m[1])) << "TYPE before HELP: " << line;
      EXPECT_TRUE(types.emplace(m[1], m[2]).second) << "two TYPE lines for " << m[1];
      EXPECT_EQ(m[1].str().rfind("lensfarm_", 0), 0u) << "metric names start with lensfarm_: " << line;
      EXPECT_TRUE(m[2] != "counter" || std::regex_search(m[1].str(), std::regex("_total$")))
          << "a counter's name ends in _total: " << line;
    } else if (std::regex_match(line, m, sample)) {
      EXPECT_TRUE(types.count(m[1])) << "a sample without HELP and TYPE before it: " << line;
      char* end = nullptr;
      const std::string value = m[3];
      const double v = std::strtod(value.c_str(), &end);
      EXPECT_EQ(end, value.c_str() + value.size()) << "not a number: " << line;
      EXPECT_TRUE(samples.emplace(m[1].str() + m[2].str(), v).second) << "a sample twice: " << line;
    } else {
      ADD_FAILURE() << "not a line of the Prometheus text format: \"" << line << "\"";
    }
  }
  return samples;
}

std::string httpGet(const std::string& address, const std::string& path, const std::string& netns) {
  std::string body;
  // setns() moves only the calling thread, so the request gets a thread of its own.
  std::thread request([&] {
    if (!netns.empty()) {
      const int fd = ::open(("/run/netns/" + netns).c_str(), O_RDONLY | O_CLOEXEC);
      const bool entered = fd >= 0 && ::setns(fd, CLONE_NEWNET) == 0;
      if (fd >= 0) ::close(fd);
      if (!entered) return;
    }
    httplib::Client client(address.substr(0, address.rfind(':')), portOf(address));
    client.set_connection_timeout(3);
    client.set_read_timeout(5);
    if (auto response = client.Get(path.c_str()); response && response->status == 200) body = response->body;
  });
  request.join();
  return body;
}

std::string grpcHealth(const std::string& address) {
  auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::CompletionQueue queue;
  // HealthCheckRequest{service = ""}, the service field written out: tag 0x0a, length 0.
  grpc::Slice field("\x0a\x00", 2);
  const grpc::ByteBuffer request(&field, 1);
  auto call = stub.PrepareUnaryCall(&context, "/grpc.health.v1.Health/Check", request, &queue);
  call->StartCall();
  grpc::ByteBuffer response;
  grpc::Status status;
  call->Finish(&response, &status, nullptr);
  void* tag = nullptr;
  bool ok = false;
  queue.Next(&tag, &ok);
  queue.Shutdown();
  while (queue.Next(&tag, &ok)) {
  }
  if (!status.ok()) return status.error_message();
  std::vector<grpc::Slice> slices;
  (void)response.Dump(&slices);
  std::string bytes;
  for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  // HealthCheckResponse{status = 1}: field 1 as a varint (0x08), then the enum's value.
  const int value = bytes.size() == 2 && bytes[0] == '\x08' ? bytes[1] : bytes.empty() ? 0 : -1;
  switch (value) {
    case 0: return "UNKNOWN";
    case 1: return "SERVING";
    case 2: return "NOT_SERVING";
    case 3: return "SERVICE_UNKNOWN";
    default: return "unexpected response of " + std::to_string(bytes.size()) + " bytes";
  }
}

void makeCertificates(const TempDir& dir, const std::string& serverAltNames) {
  const auto openssl = [](std::vector<std::string> args) {
    args.insert(args.begin(), "/usr/bin/openssl");
    const ProcessResult r = runProcess(args, 60);
    if (r.exitCode != 0) throw std::runtime_error("openssl " + args[1] + ": " + r.err);
  };
  const auto p = [&](const std::string& name) { return (dir / name).string(); };
  openssl({"req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", p("ca.key"), "-out", p("ca.pem"), "-days", "1",
           "-subj", "/CN=lensfarm test CA"});
  for (const std::string who : {"server", "client"}) {
    dir.write(who + ".ext", "subjectAltName=" + (who == "server" ? serverAltNames : "DNS:client") + "\n");
    openssl({"req", "-newkey", "rsa:2048", "-nodes", "-keyout", p(who + ".key"), "-out", p(who + ".csr"), "-subj",
             "/CN=" + who});
    openssl({"x509", "-req", "-in", p(who + ".csr"), "-CA", p("ca.pem"), "-CAkey", p("ca.key"), "-CAcreateserial",
             "-out", p(who + ".pem"), "-days", "1", "-extfile", p(who + ".ext")});
  }
}

std::map<fs::path, std::set<std::string>> debianOwnersOf(const std::vector<fs::path>& files) {
  // Each file by every name dpkg may know it under: as given, its real path, and either with or
  // without the /usr of a merged /usr. One dpkg -S for all (it reads the whole package database).
  std::map<std::string, std::vector<fs::path>> names;
  std::map<fs::path, std::set<std::string>> owners;
  for (const fs::path& file : files) {
    owners[file];
    std::vector<std::string> spellings = {file.string()};
    std::error_code ec;
    if (const fs::path real = fs::canonical(file, ec); !ec) spellings.push_back(real.string());
    for (size_t i = 0, n = spellings.size(); i < n; ++i)
      spellings.push_back(spellings[i].rfind("/usr/", 0) == 0 ? spellings[i].substr(4) : "/usr" + spellings[i]);
    for (const std::string& name : spellings) names[name].push_back(file);
  }
  std::vector<std::string> argv = {"/usr/bin/dpkg", "-S"};
  for (const auto& [name, unused] : names) argv.push_back(name);
  // Exit 1 when some name is unknown; the known ones are still listed, one a line:
  // "libfoo1:amd64: /usr/lib/...", or "a, b: /path" when several packages list it.
  const ProcessResult r = runProcess(argv, 120);
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    const size_t colon = line.find(": /");
    if (line.rfind("diversion", 0) == 0 || colon == std::string::npos) continue;
    std::istringstream packages(line.substr(0, colon));
    for (std::string package; std::getline(packages, package, ',');) {
      package = words(package).empty() ? "" : words(package)[0];
      package = package.substr(0, package.find(':'));
      if (package.empty()) continue;
      for (const fs::path& file : names[line.substr(colon + 2)]) owners[file].insert(package);
    }
  }
  return owners;
}

std::map<fs::path, std::optional<std::string>> debianPackagesOf(const std::vector<fs::path>& files) {
  std::map<fs::path, std::optional<std::string>> out;
  for (const auto& [file, owners] : debianOwnersOf(files))
    out[file] = owners.empty() ? std::nullopt : std::optional<std::string>(*owners.begin());
  return out;
}

std::optional<std::string> debianPackageOf(const fs::path& file) { return debianPackagesOf({file})[file]; }

std::set<std::string> debianDependsOf(const std::string& package) {
  const ProcessResult r = runProcess({"/usr/bin/dpkg-query", "-W", "-f=${Depends}", package}, 30);
  std::set<std::string> out;
  std::istringstream in(r.out);
  for (std::string item; std::getline(in, item, ',');) {
    const std::vector<std::string> w = words(item.substr(0, item.find('|')));
    if (!w.empty()) out.insert(w[0].substr(0, w[0].find(':')));
  }
  return out;
}

}  // namespace lensfarm::test
