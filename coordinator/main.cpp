// lensfarm-coordinator: serves the client and worker services on one port.
//
//   lensfarm-coordinator --listen 0.0.0.0:7878
//   lensfarm-coordinator --listen 127.0.0.1:0 --port-file /tmp/port   (port 0: pick a free one)
//   lensfarm-coordinator --metrics-listen 0.0.0.0:9464                (Prometheus metrics over HTTP)
//   lensfarm-coordinator --dashboard-listen 127.0.0.1:8080             (the web dashboard, docs/dashboard.md;
//                                                                       HTTPS with --tls-cert)
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <malloc.h>
#include <netinet/in.h>
#include <CLI/CLI.hpp>
#include <cstdio>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include "common/farm/memory_estimate.h"
#include "common/film/image_io.h"
#include "common/util/error.h"
#include "common/util/file_contents.h"
#include "common/util/flag_checks.h"
#include "common/util/hash.h"
#include "common/util/listen_check.h"
#include "common/util/log_text.h"
#include "common/util/logging.h"
#include "common/util/secret.h"
#include "common/util/service_flags.h"
#include "common/util/version.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/core/metrics.h"
#include "coordinator/rpc/service.h"
#include "coordinator/rpc/users.h"
#include "coordinator/web/dashboard.h"
#include "coordinator/web/dashboard_server.h"
#include "coordinator/web/metrics_server.h"
#include "coordinator/web/openapi.h"
#include "coordinator/web/rest_api.h"
#include "coordinator/web/webhooks.h"

namespace {
std::atomic<bool> gStop{false};

// True for localhost, 127.0.0.0/8 and ::1 (also in brackets).
bool isLoopback(std::string host) {
  if (host == "localhost") return true;
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  in_addr v4{};
  if (::inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (::inet_pton(AF_INET6, host.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  return false;
}

std::string readFileOrThrow(const std::string& file, const char* flag) {
  return lensfarm::readWholeFileOrThrow(file, std::string(flag) + " " + file);
}
// Writes "HOST:PORT\n" atomically; InputError names the flag.
void writeAddressFile(const std::string& file, const std::string& address, const char* flag) {
  try {
    lensfarm::writeBytesAtomically(file, address + "\n");
  } catch (const lensfarm::InputError& e) {
    throw lensfarm::InputError(flag, e.what());
  }
}
extern "C" void onSignal(int) { gStop = true; }

using namespace lensfarm;

// Everything the command line sets.
struct Flags {
  std::string listen = "127.0.0.1:7878", portFile, logLevel = "info";
  std::string clientTokenFile, workerTokenFile, workerCredentialsFile, viewerTokenFile, tlsCert, tlsKey, tlsClientCa;
  std::string usersFile;
  std::string metricsListen, metricsPortFile, dashboardListen, dashboardPortFile;
  std::string stateDir, uploadEncoding = "shuffle-zstd", maxJobMemory, memoryBudget, maxAssetBytes, keep = "0",
                        archiveAfter = "0", assetGrace = "1h", maxAssetBytesPerOwner;
  std::string sharing = "fair";
  std::vector<std::string> ownerWeights;  // NAME=WEIGHT
  std::string webhookSecretFile, webhookEvents;
  WebhookOptions webhooks;
  Coordinator::Options options;
};

// Where the services listen, who may call them and how (tokens, TLS).
void addServingFlags(CLI::App& app, Flags& f) {
  app.add_option("--listen", f.listen, "HOST:PORT to serve on (port 0 picks a free port)")
      ->envname("LENSFARM_LISTEN")
      ->capture_default_str();
  app.add_option("--client-token-file", f.clientTokenFile,
                 "File holding the token clients must present (or set LENSFARM_CLIENT_TOKEN)");
  app.add_option("--worker-token-file", f.workerTokenFile,
                 "File holding the token workers must present (or set LENSFARM_WORKER_TOKEN)");
  app.add_option("--users", f.usersFile,
                 "File of people, one \"NAME ROLE SHA256-OF-TOKEN\" a line (roles admin, submitter, viewer): each "
                 "uses the client service with a token of their own, owns the jobs they submit and acts on their own "
                 "only unless admin (docs/farm.md \"People and permissions\"); needs --client-token-file")
      ->envname("LENSFARM_USERS");
  app.add_option("--worker-credentials", f.workerCredentialsFile,
                 "File of per-machine worker credentials, one \"NAME TOKEN\" a line: each registers one worker at "
                 "a time and counts as one machine in failures and audits (docs/farm.md \"Worker identity\"); with "
                 "or instead of --worker-token-file")
      ->envname("LENSFARM_WORKER_CREDENTIALS");
  app.add_option("--viewer-token-file", f.viewerTokenFile,
                 "File holding a read-only token: on the dashboard it shows jobs, workers and images but cannot "
                 "cancel or reprioritize; on gRPC it opens only the reading calls (GetJob, ListJobs, WatchJob, "
                 "Download, GetSnapshot, ListWorkers) (or set LENSFARM_VIEWER_TOKEN to the token itself); needs a "
                 "client token")
      ->envname("LENSFARM_VIEWER_TOKEN_FILE");
  app.add_option("--tls-cert", f.tlsCert, "PEM server certificate chain: serve TLS")->envname("LENSFARM_TLS_CERT");
  app.add_option("--tls-key", f.tlsKey, "PEM private key of --tls-cert")->envname("LENSFARM_TLS_KEY");
  app.add_option("--tls-client-ca", f.tlsClientCa, "PEM CA: require and verify client certificates")
      ->envname("LENSFARM_TLS_CLIENT_CA");
  app.add_option("--port-file", f.portFile, "Write the address actually listened on to this file")
      ->envname("LENSFARM_PORT_FILE");
}

// Leases, failures and the audit (docs/farm.md).
void addSchedulingFlags(CLI::App& app, Coordinator::Options& options) {
  app.add_option("--lease-timeout", options.leaseTimeoutSeconds, "Seconds without a heartbeat before a lease lapses")
      ->envname("LENSFARM_LEASE_TIMEOUT")
      ->check(numberIn(0.1, 86400.0, "seconds"))
      ->capture_default_str();
  app.add_option("--heartbeat-interval", options.heartbeatIntervalSeconds, "Seconds between worker heartbeats")
      ->envname("LENSFARM_HEARTBEAT_INTERVAL")
      ->check(numberIn(0.01, 3600.0, "seconds"))
      ->capture_default_str();
  app.add_option("--max-lease", options.maxLeaseSeconds,
                 "Seconds a lease may be held however often it is extended: a worker that heartbeats without "
                 "uploading loses its unit after this")
      ->envname("LENSFARM_MAX_LEASE")
      ->check(numberIn(1.0, 30.0 * 86400.0, "seconds"))
      ->capture_default_str();
  app.add_option("--max-failures-per-worker", options.maxFailuresPerWorker,
                 "Failures of one job on one worker after which that worker is not leased the job again")
      ->envname("LENSFARM_MAX_FAILURES_PER_WORKER")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--max-unit-failures", options.maxUnitFailures,
                 "Different workers a unit may fail on before its job fails with their reasons")
      ->envname("LENSFARM_MAX_UNIT_FAILURES")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--audit-fraction", options.auditFraction,
                 "Fraction of units rendered again by another worker and compared (0: no audit)")
      ->envname("LENSFARM_AUDIT_FRACTION")
      ->check(numberIn(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--audit-tolerance", options.auditTolerance,
                 "Largest relative difference, per cell and channel, between an audited unit's two results that "
                 "still agrees")
      ->envname("LENSFARM_AUDIT_TOLERANCE")
      ->check(nonNegativeNumber(""))
      ->capture_default_str();
  app.add_option("--audit-wait", options.auditWaitSeconds,
                 "Seconds a job with every unit in waits for its audits to be taken; then an audit no worker "
                 "took is waived, with an event")
      ->envname("LENSFARM_AUDIT_WAIT")
      ->check(numberIn(0.0, 86400.0, "seconds"))
      ->capture_default_str();
}

// The metrics endpoint and the dashboard.
void addHttpFlags(CLI::App& app, Flags& f) {
  app.add_option("--metrics-listen", f.metricsListen,
                 "HOST:PORT to serve Prometheus metrics on over HTTP (GET /metrics; port 0 picks a free port); "
                 "empty: off")
      ->envname("LENSFARM_METRICS_LISTEN");
  app.add_option("--metrics-port-file", f.metricsPortFile,
                 "Write the metrics address actually listened on to this file")
      ->envname("LENSFARM_METRICS_PORT_FILE");
  app.add_option("--dashboard-listen", f.dashboardListen,
                 "HOST:PORT to serve the web dashboard on, over HTTPS with --tls-cert and --tls-key, else HTTP (port 0 "
                 "picks a free port; its /api needs the client or viewer token); empty: off")
      ->envname("LENSFARM_DASHBOARD_LISTEN");
  app.add_option("--dashboard-port-file", f.dashboardPortFile,
                 "Write the dashboard address actually listened on to this file")
      ->envname("LENSFARM_DASHBOARD_PORT_FILE");
  // Webhooks (webhooks.h, docs/api.md "Webhooks").
  app.add_option("--webhook", f.webhooks.urls,
                 "POST the farm's events as signed JSON to this http:// or https:// URL, at least once, in order "
                 "(repeatable)");
  app.add_option("--webhook-secret-file", f.webhookSecretFile,
                 "File holding the webhooks' HMAC-SHA256 key (or set LENSFARM_WEBHOOK_SECRET)");
  app.add_option("--webhook-events", f.webhookEvents,
                 "Comma-separated event types to send (e.g. job.done,job.failed,worker.lost); empty: all")
      ->envname("LENSFARM_WEBHOOK_EVENTS");
  app.add_option("--webhook-attempts", f.webhooks.attempts,
                 "Tries per event before it is given up (waits 1, 2, 4, ... s between, at most 60 s)")
      ->envname("LENSFARM_WEBHOOK_ATTEMPTS")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
}

// The webhooks' options from the flags; InputError naming the flag.
WebhookOptions webhookOptions(const Flags& f) {
  WebhookOptions w = f.webhooks;
  if (w.urls.empty()) return w;
  if (const auto secret = readToken(f.webhookSecretFile, "LENSFARM_WEBHOOK_SECRET")) {
    checkTokenStrength(*secret, f.webhookSecretFile.empty() ? "LENSFARM_WEBHOOK_SECRET" : f.webhookSecretFile);
    w.secret = *secret;
  }
  for (size_t start = 0; start < f.webhookEvents.size();) {
    const size_t comma = std::min(f.webhookEvents.find(',', start), f.webhookEvents.size());
    if (comma > start) w.types.insert(f.webhookEvents.substr(start, comma - start));
    start = comma + 1;
  }
  checkWebhookOptions(w);
  return w;
}

// Durable state, uploads, memory and the job life cycle (docs/farm.md "Job life cycle").
void addStateFlags(CLI::App& app, Flags& f) {
  app.add_option("--state-dir", f.stateDir,
                 "Keep jobs, assets, the unit ledger and sensors here (SQLite + files) "
                 "and resume them after a restart; empty: in memory only")
      ->envname("LENSFARM_STATE_DIR");
  app.add_option("--checkpoint-every", f.options.checkpointEverySeconds,
                 "Seconds between saves of the accumulated sensors (units are durable before they are acknowledged)")
      ->envname("LENSFARM_CHECKPOINT_EVERY")
      ->check(numberIn(0.01, 86400.0, "seconds"))
      ->capture_default_str();
  app.add_option("--upload-encoding", f.uploadEncoding,
                 "How workers are asked to upload unit sums: shuffle-zstd (byte-shuffled doubles, zstd level 1, "
                 "lossless) or raw (the doubles as they are); uploads in either are accepted")
      ->envname("LENSFARM_UPLOAD_ENCODING")
      ->check(CLI::IsMember({"shuffle-zstd", "raw"}))
      ->capture_default_str();
  app.add_option("--max-job-memory", f.maxJobMemory,
                 "Memory one job may take (e.g. 16G, 512MiB): bigger jobs are refused at submission with their "
                 "estimate; default 3/4 of this machine's memory (or of its cgroup limit)")
      ->envname("LENSFARM_MAX_JOB_MEMORY");
  app.add_option("--memory-budget", f.memoryBudget,
                 "Memory all jobs, downloads and (without --state-dir) assets may take together (e.g. 48G): a job "
                 "that does not fit beside the others is refused, a download waits for room; default as "
                 "--max-job-memory's")
      ->envname("LENSFARM_MEMORY_BUDGET");
  app.add_option("--max-asset-bytes", f.maxAssetBytes,
                 "The most bytes of uploaded assets the coordinator keeps (e.g. 100G); an upload past it is refused "
                 "(default: no limit)")
      ->envname("LENSFARM_MAX_ASSET_BYTES");
  app.add_option("--max-asset-bytes-per-owner", f.maxAssetBytesPerOwner,
                 "The most bytes of distinct assets one owner's jobs may refer to (e.g. 20G); a submit past it is "
                 "refused (default: no limit)")
      ->envname("LENSFARM_MAX_ASSET_BYTES_PER_OWNER");
  app.add_option("--max-samples-per-owner", f.options.maxSamplesPerOwner,
                 "The most pixel-samples one owner's queued and running jobs may have still to render (e.g. "
                 "1000000000000); a submit past it is refused (0: no limit)")
      ->envname("LENSFARM_MAX_SAMPLES_PER_OWNER")
      ->capture_default_str();
  app.add_option("--asset-grace", f.assetGrace,
                 "Remove an uploaded asset once no job has referred to it for this long (e.g. 1h, 30m; archived "
                 "jobs count, deleted ones do not); \"never\": keep every asset")
      ->envname("LENSFARM_ASSET_GRACE")
      ->capture_default_str();
  app.add_option("--max-jobs-per-owner", f.options.maxJobsPerOwner,
                 "Jobs one owner may have queued or running at once; a submit past it is refused (0: no cap)")
      ->envname("LENSFARM_MAX_JOBS_PER_OWNER")
      ->capture_default_str();
  app.add_option("--sharing", f.sharing,
                 "Jobs of equal priority: fair (shared between owners by weight, then between an owner's jobs) "
                 "or fifo (in submission order); higher priorities always come first")
      ->envname("LENSFARM_SHARING")
      ->check(CLI::IsMember({"fair", "fifo"}))
      ->capture_default_str();
  app.add_option("--owner-weight", f.ownerWeights,
                 "An owner's share of the farm under fair sharing, NAME=WEIGHT (repeat, or comma-separated); "
                 "owners not listed weigh 1")
      ->envname("LENSFARM_OWNER_WEIGHTS")
      ->delimiter(',');
  app.add_option("--keep", f.keep,
                 "Delete jobs this long after they ended (e.g. 7d, 12h, 30m, 3600s); 0: keep them forever")
      ->envname("LENSFARM_KEEP")
      ->capture_default_str();
  app.add_option("--archive-after", f.archiveAfter,
                 "Archive jobs this long after they ended: keep the final image, free the sensor and ledger "
                 "(0: at once; \"never\": keep everything)")
      ->envname("LENSFARM_ARCHIVE_AFTER")
      ->capture_default_str();
}

// A size flag given as `text` ("16G", "512MiB", "2000000000") into `bytes` (unchanged when not
// given); false after one error line naming `flag` when it is not a size.
bool parseSizeFlag(const std::string& text, const char* flag, uint64_t& bytes) {
  if (text.empty()) return true;
  bytes = parseByteSize(text);
  if (bytes == 0)
    spdlog::error("{}: expected a size such as 16G, 512MiB or 2000000000 (bytes), got \"{}\"", flag, text);
  return bytes != 0;
}

// The options that need more than CLI11's checks; an exit code (2) after one clear error line.
std::optional<int> finishOptions(Flags& f) {
  if (!parseSizeFlag(f.maxJobMemory, "--max-job-memory", f.options.maxJobMemoryBytes) ||
      !parseSizeFlag(f.maxAssetBytes, "--max-asset-bytes", f.options.maxAssetBytes) ||
      !parseSizeFlag(f.maxAssetBytesPerOwner, "--max-asset-bytes-per-owner", f.options.maxAssetBytesPerOwner) ||
      !parseSizeFlag(f.memoryBudget, "--memory-budget", f.options.memoryBudgetBytes))
    return 2;
  if (!f.maxJobMemory.empty()) f.options.maxJobMemorySource = "--max-job-memory";
  if (!f.memoryBudget.empty()) f.options.memoryBudgetSource = "--memory-budget";
  try {
    f.options.keepSeconds = parseDuration(f.keep, "--keep");
    f.options.archiveAfterSeconds = f.archiveAfter == "never" ? -1.0 : parseDuration(f.archiveAfter, "--archive-after");
    f.options.assetGraceSeconds = f.assetGrace == "never" ? -1.0 : parseDuration(f.assetGrace, "--asset-grace");
  } catch (const InputError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  f.options.stateDir = f.stateDir;
  f.options.sharing =
      f.sharing == "fifo" ? Coordinator::Options::Sharing::kFifo : Coordinator::Options::Sharing::kFairShare;
  for (const std::string& entry : f.ownerWeights) {
    const size_t eq = entry.rfind('=');
    double weight = 0.0;
    size_t used = 0;
    try {
      if (eq != std::string::npos) weight = std::stod(entry.substr(eq + 1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (eq == std::string::npos || eq == 0 || used == 0 || used != entry.size() - eq - 1 || !(weight > 0.0) ||
        !(weight <= 1e6)) {
      spdlog::error("--owner-weight: expected NAME=WEIGHT with a weight above 0 and at most 1e6, got \"{}\"",
                    logText(entry));
      return 2;
    }
    f.options.ownerWeights[entry.substr(0, eq)] = weight;
  }
  return std::nullopt;
}

// The tokens per service and the gRPC credentials (TLS if certificates are given).
struct Security {
  std::optional<std::string> clientToken, workerToken, viewerToken;
  std::vector<WorkerCredential> workerCredentials;
  std::vector<User> users;
  bool workersAuthenticated() const { return workerToken || !workerCredentials.empty(); }
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
};

// Reads and checks the tokens and certificates; InputError naming the flag or variable.
Security readSecurity(const Flags& f) {
  Security s;
  s.clientToken = readToken(f.clientTokenFile, "LENSFARM_CLIENT_TOKEN");
  s.workerToken = readToken(f.workerTokenFile, "LENSFARM_WORKER_TOKEN");
  if (s.clientToken)
    checkTokenStrength(*s.clientToken, f.clientTokenFile.empty() ? "LENSFARM_CLIENT_TOKEN" : f.clientTokenFile);
  if (s.workerToken)
    checkTokenStrength(*s.workerToken, f.workerTokenFile.empty() ? "LENSFARM_WORKER_TOKEN" : f.workerTokenFile);
  if (s.clientToken && s.workerToken && equalSecrets(*s.clientToken, *s.workerToken))
    throw InputError("--worker-token-file", "workers and clients need different tokens");
  if (!f.workerCredentialsFile.empty()) {
    s.workerCredentials = readWorkerCredentials(f.workerCredentialsFile);
    for (const WorkerCredential& c : s.workerCredentials)
      if ((s.clientToken && equalSecrets(c.token, *s.clientToken)) ||
          (s.workerToken && equalSecrets(c.token, *s.workerToken)))
        throw InputError(f.workerCredentialsFile, "the token of credential " + c.name +
                                                      " is also the client or shared worker token: each needs its own");
  }
  if (!f.usersFile.empty()) {
    if (!s.clientToken)
      throw InputError("--users", "people need the administrators' client token too (--client-token-file)");
    s.users = readUsers(f.usersFile);
    for (const User& u : s.users)
      if (!u.certificateName.empty() && f.tlsClientCa.empty())
        throw InputError(f.usersFile, u.name + " is known by a client certificate (cert=" + u.certificateName +
                                          "): that needs mutual TLS (--tls-client-ca)");
    for (const User& u : s.users)
      if (equalSecrets(u.tokenSha256, sha256Hex(*s.clientToken)) ||
          (s.workerToken && equalSecrets(u.tokenSha256, sha256Hex(*s.workerToken))))
        throw InputError(f.usersFile, "the token of " + u.name + " is the client or worker token: each needs its own");
  }
  s.viewerToken = readToken(f.viewerTokenFile, "LENSFARM_VIEWER_TOKEN");
  if (s.viewerToken) {
    const char* viewerFlag = "--viewer-token-file";
    checkTokenStrength(*s.viewerToken, f.viewerTokenFile.empty() ? "LENSFARM_VIEWER_TOKEN" : f.viewerTokenFile);
    if (!s.clientToken)
      throw InputError(viewerFlag,
                       "a viewer token needs a client token (--client-token-file): without one the "
                       "dashboard is open to anyone on this machine");
    bool workers = s.workerToken && equalSecrets(*s.viewerToken, *s.workerToken);
    for (const WorkerCredential& c : s.workerCredentials) workers |= equalSecrets(*s.viewerToken, c.token);
    if (equalSecrets(*s.viewerToken, *s.clientToken) || workers)
      throw InputError(viewerFlag, "viewers need a token of their own, different from the client and worker tokens");
  }
  if (!f.tlsClientCa.empty() && f.tlsCert.empty())
    throw InputError("--tls-client-ca", "client certificates need TLS: give --tls-cert and --tls-key too");
  if (f.tlsCert.empty() != f.tlsKey.empty())
    throw InputError(f.tlsCert.empty() ? "--tls-key" : "--tls-cert", "give both --tls-cert and --tls-key");
  if (!f.tlsCert.empty()) {
    grpc::SslServerCredentialsOptions tls(f.tlsClientCa.empty()
                                              ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                                              : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
    tls.pem_key_cert_pairs.push_back(
        {readFileOrThrow(f.tlsKey, "--tls-key"), readFileOrThrow(f.tlsCert, "--tls-cert")});
    if (!f.tlsClientCa.empty()) tls.pem_root_certs = readFileOrThrow(f.tlsClientCa, "--tls-client-ca");
    s.credentials = grpc::SslServerCredentials(tls);
  }
  return s;
}

// No open door to the network: a non-loopback address needs the tokens; an error line and exit
// code 2, else warnings for what crosses the network in the clear.
std::optional<int> refuseOpenDoors(const Flags& f, const Security& s) {
  const std::string host = f.listen.substr(0, f.listen.rfind(':'));
  const bool loopback = isLoopback(host);
  if (!loopback && !(s.clientToken && s.workersAuthenticated())) {
    spdlog::error(
        "refusing to listen on {} without --client-token-file and --worker-token-file: anyone who can "
        "reach it could submit jobs or lease work. Give both tokens, or listen on 127.0.0.1.",
        f.listen);
    return 2;
  }
  // (A malformed address is refused with its own message when the dashboard starts.)
  if (const size_t colon = f.dashboardListen.rfind(':');
      colon != std::string::npos && colon > 0 && !isLoopback(f.dashboardListen.substr(0, colon)) && !s.clientToken) {
    spdlog::error(
        "refusing to serve the dashboard on {} without --client-token-file: anyone who can reach it could "
        "cancel jobs. Give a client token, or listen on 127.0.0.1.",
        f.dashboardListen);
    return 2;
  }
  // On loopback one token without the other protects one service and leaves the other to any
  // local user: said loudly, since it looks protected.
  if (s.clientToken && !s.workersAuthenticated())
    spdlog::warn(
        "the worker service takes no token (no --worker-token-file): any user of this machine can register a "
        "worker, read every queued job's scene and assets, and send results. Give a worker token too.");
  if (s.workersAuthenticated() && !s.clientToken)
    spdlog::warn(
        "the client service takes no token (no --client-token-file): any user of this machine can submit, "
        "download and cancel jobs. Give a client token too.");
  if (!loopback && f.tlsCert.empty())
    spdlog::warn("serving {} without TLS: tokens and images cross the network in the clear", f.listen);
  if (const size_t colon = f.dashboardListen.rfind(':');
      colon != std::string::npos && colon > 0 && !isLoopback(f.dashboardListen.substr(0, colon)) && f.tlsCert.empty())
    spdlog::warn("serving the dashboard on {} without TLS: tokens and images cross the network in the clear",
                 f.dashboardListen);
  return std::nullopt;
}

// Each address checked before any server takes one: a port in use is one line naming its flag.
std::optional<int> refuseBusyAddresses(const Flags& f) {
  for (const auto& [flag, address] : {std::pair<const char*, const std::string*>{"--listen", &f.listen},
                                      {"--metrics-listen", &f.metricsListen},
                                      {"--dashboard-listen", &f.dashboardListen}}) {
    if (address->empty()) continue;
    if (const std::optional<std::string> problem = listenProblem(*address)) {
      std::fprintf(stderr, "lensfarm-coordinator: error: %s %s: %s\n", flag, address->c_str(), problem->c_str());
      return 2;
    }
  }
  return std::nullopt;
}

// The gRPC server with both services, keepalive as docs/farm.md "Failures" says; its port into
// `port` (0: it could not listen).
std::unique_ptr<grpc::Server> startGrpc(const Flags& f, const Security& s, ClientServiceImpl& clientService,
                                        WorkerServiceImpl& workerService, int& port) {
  grpc::ServerBuilder builder;
  // Without SO_REUSEPORT (gRPC's default on Linux), a second coordinator on the same port fails
  // to start instead of silently sharing the port's connections with the first.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  // Keepalive: ping a connection after 5 s of quiet and drop it if no answer comes within 5 s, so
  // a worker whose machine or network died (its Attach stream open on a dead link) is lost in
  // about 10 s; and accept the workers' own pings (every 5 s, also between calls;
  // proto/channel_security.h) instead of answering them with GOAWAY.
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, 5000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 5000);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 4000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  // A backstop on the sync handlers' threads (long streams use the callback API, and each role's
  // Downloads are capped): past it a call is RESOURCE_EXHAUSTED instead of a thread more. A farm
  // of 1,000 workers long-polling LeaseWork holds about 1,000.
  grpc::ResourceQuota quota("lensfarm-coordinator");
  quota.SetMaxThreads(4096);
  builder.SetResourceQuota(quota);
  builder.AddListeningPort(f.listen, s.credentials, &port);
  builder.RegisterService(&clientService);
  builder.RegisterService(&workerService);
  return builder.BuildAndStart();
}

// The HTTP servers (metrics, dashboard) and the address files; throws InputError or another
// exception (the caller shuts the gRPC server down).
struct HttpServers {
  std::unique_ptr<MetricsServer> metrics;
  std::unique_ptr<DashboardServer> dashboard;
};
HttpServers startHttp(const Flags& f, const Security& s, Coordinator& coordinator, Dashboard& dashboard, RestApi& api,
                      const std::string& address) {
  HttpServers h;
  if (!f.metricsListen.empty()) {
    h.metrics = std::make_unique<MetricsServer>(
        f.metricsListen, [&coordinator] { return renderMetrics(coordinator.metricsSnapshot()); });
    spdlog::info("metrics on http://{}/metrics", h.metrics->address());
  }
  if (!f.dashboardListen.empty()) {
    // The same certificate (and client CA) as the gRPC services.
    std::optional<HttpTls> dashboardTls;
    if (!f.tlsCert.empty()) dashboardTls = HttpTls{f.tlsCert, f.tlsKey, f.tlsClientCa};
    h.dashboard = std::make_unique<DashboardServer>(f.dashboardListen, dashboard, &api, dashboardTls);
    spdlog::info("dashboard on {}://{}/ and the HTTP API under /api/v1 ({}client token {}, viewer token {})",
                 h.dashboard->scheme(), h.dashboard->address(), f.tlsClientCa.empty() ? "" : "client certificate and ",
                 s.clientToken ? "required" : "none", s.viewerToken ? "accepted (read-only)" : "none");
  }
  if (!f.portFile.empty()) writeAddressFile(f.portFile, address, "--port-file");
  if (h.metrics && !f.metricsPortFile.empty())
    writeAddressFile(f.metricsPortFile, h.metrics->address(), "--metrics-port-file");
  if (h.dashboard && !f.dashboardPortFile.empty())
    writeAddressFile(f.dashboardPortFile, h.dashboard->address(), "--dashboard-port-file");
  return h;
}

}  // namespace

int main(int argc, char** argv) {
  // Unit buffers are megabytes each: keep them out of the heap arenas (glibc would otherwise raise
  // its mmap threshold after the first frees and hold freed buffers as resident memory).
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  CLI::App app{"lensfarm-coordinator: schedules render jobs over workers and accumulates their images"};
  app.set_version_flag("--version", kRendererVersion);
  Flags f;
  addServingFlags(app, f);
  addSchedulingFlags(app, f.options);
  addHttpFlags(app, f);
  addStateFlags(app, f);
  addLogLevelOption(app, f.logLevel);
  bool printOpenApi = false;
  app.add_flag("--print-openapi", printOpenApi,
               "Print the OpenAPI 3.0 document of the HTTP API (/api/v1, docs/api.md) and exit");
  if (const auto exitCode = parseServiceFlags(app, argc, argv, "lensfarm-coordinator")) return *exitCode;
  if (printOpenApi) {
    std::fputs(openApiDocument("1").c_str(), stdout);
    return 0;
  }
  setupLogging("coordinator", f.logLevel);
  createFilesPrivately();  // the state dir holds users' scenes, assets and images
  if (const auto exitCode = finishOptions(f)) return *exitCode;
  if (!f.stateDir.empty()) makePrivateDirectory(f.stateDir, "--state-dir");

  std::unique_ptr<Coordinator> owned;
  try {
    owned = std::make_unique<Coordinator>(f.options);
  } catch (const std::exception& e) {
    spdlog::error("--state-dir {}: {}", f.stateDir, e.what());
    return 2;
  }
  Coordinator& coordinator = *owned;
  spdlog::info("a job may take up to {} of memory ({}), all of them together {} ({})",
               formatBytes(coordinator.options().maxJobMemoryBytes), coordinator.options().maxJobMemorySource,
               formatBytes(coordinator.options().memoryBudgetBytes), coordinator.options().memoryBudgetSource);

  Security security;
  try {
    security = readSecurity(f);
  } catch (const InputError& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (const auto exitCode = refuseOpenDoors(f, security)) return *exitCode;

  // The viewer token reads through gRPC too: status, watch, download, snapshots, workers.
  const TokenGate clientGate = TokenGate(security.clientToken, "client", security.viewerToken, "viewer",
                                         {"GetJob", "ListJobs", "WatchJob", "Download", "GetSnapshot", "ListWorkers",
                                          "ListEvents", "GetServerInfo"})
                                   .withUsers(security.users);
  ClientServiceImpl clientService(coordinator, clientGate);
  WorkerServiceImpl workerService(coordinator,
                                  TokenGate(security.workerToken, "worker").withCredentials(security.workerCredentials),
                                  f.uploadEncoding == "raw" ? SumsEncoding::kRaw : SumsEncoding::kShuffleZstd);
  // gRPC health checking (grpc.health.v1.Health): SERVING while the services are up, for load
  // balancers and Kubernetes gRPC probes; it needs no token.
  grpc::EnableDefaultHealthCheckService(true);
  // From here on a signal stops the coordinator cleanly, also one sent as soon as --port-file appears.
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  if (const auto exitCode = refuseBusyAddresses(f)) return *exitCode;
  int port = 0;
  std::unique_ptr<grpc::Server> server = startGrpc(f, security, clientService, workerService, port);
  if (!server || port == 0) {
    spdlog::error("cannot listen on {}", f.listen);
    return 1;
  }
  const std::string address = f.listen.substr(0, f.listen.rfind(':')) + ":" + std::to_string(port);
  spdlog::info("listening on {} ({}; {}; client token {}, worker token {})", address, kRendererVersion,
               f.tlsCert.empty() ? "plain gRPC" : (f.tlsClientCa.empty() ? "TLS" : "mutual TLS"),
               security.clientToken ? "required" : "none",
               security.workerCredentials.empty() ? (security.workerToken ? "required" : "none")
                                                  : std::to_string(security.workerCredentials.size()) + " credentials" +
                                                        (security.workerToken ? " and the shared token" : ""));
  Dashboard dashboard(coordinator, security.clientToken, security.viewerToken, security.users);
  // The HTTP/JSON API calls the client service through the gRPC server itself, in process.
  RestApi api(server->InProcessChannel(grpc::ChannelArguments()), clientGate, clientGate.enabled());
  HttpServers http;
  std::unique_ptr<WebhookSender> webhooks;
  try {
    WebhookOptions hooks = webhookOptions(f);
    if (!f.stateDir.empty()) {  // each URL's progress kept, so deliveries go on after a restart
      hooks.loadCursor = [&coordinator](const std::string& url) { return coordinator.webhookCursor(url); };
      hooks.saveCursor = [&coordinator](const std::string& url, uint64_t sequence) {
        coordinator.setWebhookCursor(url, sequence);
      };
    }
    if (!hooks.urls.empty()) {
      webhooks = std::make_unique<WebhookSender>(coordinator.events(), hooks);
      spdlog::info("webhooks: {} URL(s), events: {}", hooks.urls.size(),
                   f.webhookEvents.empty() ? "all" : f.webhookEvents);
    }
    http = startHttp(f, security, coordinator, dashboard, api, address);
  } catch (const InputError& e) {
    spdlog::error("{}", e.what());
    server->Shutdown();
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    server->Shutdown();
    return 1;
  }

  while (!gStop) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  spdlog::info("shutting down");
  server->GetHealthCheckService()->SetServingStatus(false);
  workerService.endAttachments();  // workers' streams end now (not lost), instead of at the deadline
  clientService.endWatches();
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  return 0;
}
