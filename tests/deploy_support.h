#pragma once
// Helpers for the tests of a farm as it is deployed: real coordinator, worker and CLI processes
// (optionally each inside a network namespace), the binaries' flags as their --help lists them,
// Prometheus text, gRPC health checks, throwaway TLS certificates and Debian package owners.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace lensfarm::test {

// ---- the binaries' flags ----

// The options (--name) a binary's --help lists, and the whole help text (which also names the
// environment variables it reads).
struct Help {
  std::set<std::string> flags;
  std::string text;
};
Help helpOf(const std::filesystem::path& binary);

// A command line's options as flag -> value: "--a=b" and "--a b" alike, "" for a flag with no
// value. Words that are no option's value (the program, positional arguments) are ignored.
std::multimap<std::string, std::string> optionsOf(const std::vector<std::string>& argv);
// Whether `argv` runs `binary` (argv[0] is its path, or its name for a container's PATH) with only
// options its --help lists.
::testing::AssertionResult runsWithItsFlags(const std::vector<std::string>& argv, const std::filesystem::path& binary);
// The value of `flag` in `argv` ("" if absent).
std::string optionOf(const std::vector<std::string>& argv, const std::string& flag);
// The port of HOST:PORT, or -1.
int portOf(const std::string& address);

// ---- real processes ----

// cornell-seed, the 2013 report's scene (its OBJ beside it), at size x size, `spp` samples in units of `perUnit`.
std::filesystem::path writeSeedScene(const TempDir& dir, int size, uint64_t spp, uint32_t perUnit);

// Runs farm processes for a test and kills them all when it goes away. `wrapper` (e.g.
// {"ip", "netns", "exec", "host"}) is put before a command to run it elsewhere.
class FarmProcesses {
 public:
  explicit FarmProcesses(const TempDir& dir) : dir_(dir) {}

  // Starts lensfarm-coordinator with `args` plus --port-file (and --metrics-port-file when
  // `args` has --metrics-listen, --dashboard-port-file when it has --dashboard-listen); waits
  // until it serves. Returns its address; throws if it exits.
  std::string startCoordinator(std::vector<std::string> args, const std::vector<std::string>& wrapper = {});
  const std::string& metricsAddress() const { return metricsAddress_; }
  const std::string& dashboardAddress() const { return dashboardAddress_; }
  ChildProcess& coordinator() { return *coordinator_; }

  // Starts lensfarm-worker with `args` plus --name, a cache dir of its own and a short backoff.
  ChildProcess& startWorker(const std::string& name, std::vector<std::string> args,
                            const std::vector<std::string>& wrapper = {});

  // Runs the `lensfarm` CLI with `args` to completion.
  ProcessResult cli(std::vector<std::string> args, const std::vector<std::string>& wrapper = {}) const;
  // `lensfarm submit` (exit 0 expected); returns the job id.
  std::string submit(std::vector<std::string> args, const std::vector<std::string>& wrapper = {}) const;

 private:
  const TempDir& dir_;
  std::unique_ptr<ChildProcess> coordinator_;
  std::vector<std::unique_ptr<ChildProcess>> workers_;
  std::string metricsAddress_;
  std::string dashboardAddress_;
  int started_ = 0;
};

// The line of a table (e.g. `lensfarm workers` output) with ` name ` in it, or "".
std::string lineOf(const std::string& table, const std::string& name);

// ---- observability ----

// The samples of a Prometheus text exposition: "name" or "name{labels}" -> value. Adds a test
// failure for a malformed line, a sample of a family without HELP and TYPE before it, a name
// outside lensfarm_*, or a counter whose name does not end in _total.
std::map<std::string, double> parseMetrics(const std::string& text);

// GET http://ADDRESS/PATH; the body, or "" if the request failed. With `netns`, the request is
// made from inside that network namespace (/run/netns/NAME).
std::string httpGet(const std::string& address, const std::string& path, const std::string& netns = "");

// grpc.health.v1.Health/Check of the whole server at `address` (plain gRPC): "SERVING",
// "NOT_SERVING", ... or the failed call's message.
std::string grpcHealth(const std::string& address);

// ---- security ----

// A throwaway CA (ca.pem, ca.key) and, signed by it, server.pem/server.key with the given
// subjectAltName (e.g. "IP:127.0.0.1,DNS:localhost") and client.pem/client.key, all in `dir`.
// Throws with openssl's message if it fails.
void makeCertificates(const TempDir& dir, const std::string& serverAltNames);

// ---- the system ----

// Every Debian package dpkg lists as installing each file (found by its own path, its real path,
// or either with or without the /usr of a merged /usr), without the architecture; empty if none.
// One dpkg -S for all files.
std::map<std::filesystem::path, std::set<std::string>> debianOwnersOf(const std::vector<std::filesystem::path>& files);
// The first of those packages, by name; nullopt if none.
std::map<std::filesystem::path, std::optional<std::string>> debianPackagesOf(
    const std::vector<std::filesystem::path>& files);
std::optional<std::string> debianPackageOf(const std::filesystem::path& file);
// The packages named in an installed package's Depends field (versions and alternatives after
// the first dropped).
std::set<std::string> debianDependsOf(const std::string& package);

// Words of `text` (split on white space).
std::vector<std::string> words(const std::string& text);

}  // namespace lensfarm::test
