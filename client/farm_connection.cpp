#include "client/farm_connection.h"

#include <cstdio>

#include "client/exit_codes.h"
#include "client/farm_client.h"

namespace lensfarm::cli {

void addCoordinatorOption(CLI::App* cmd, Connection& c) {
  cmd->add_option("--coordinator", c.coordinator, "Coordinator address HOST:PORT")
      ->envname("LENSFARM_COORDINATOR")
      ->capture_default_str();
  cmd->add_option("--token-file", c.tokenFile, "File holding the farm's client token (or set LENSFARM_TOKEN)");
  cmd->add_option("--tls-ca", c.security.caFile, "PEM CA certificate(s) to verify the coordinator: enables TLS")
      ->envname("LENSFARM_TLS_CA");
  cmd->add_option("--tls-cert", c.security.certFile, "PEM client certificate, for coordinators that require one")
      ->envname("LENSFARM_TLS_CERT");
  cmd->add_option("--tls-key", c.security.keyFile, "PEM private key of --tls-cert")->envname("LENSFARM_TLS_KEY");
}

void addJobArgs(CLI::App* cmd, JobArgs& f) {
  addCoordinatorOption(cmd, f.c);
  cmd->add_option("job", f.job, "Job id")->required();
}

int guardedCall(const std::function<int()>& body) {
  try {
    return body();
  } catch (const ClientError& e) {
    std::fprintf(stderr, "lensfarm: error: %s\n", e.what());
    switch (e.code()) {
      case grpc::StatusCode::INVALID_ARGUMENT:
      case grpc::StatusCode::FAILED_PRECONDITION:
      case grpc::StatusCode::RESOURCE_EXHAUSTED: return kBadInput;  // e.g. a job bigger than --max-job-memory
      case grpc::StatusCode::NOT_FOUND: return kNotFound;
      case grpc::StatusCode::UNAVAILABLE:
      case grpc::StatusCode::DEADLINE_EXCEEDED: return kUnavailable;
      case grpc::StatusCode::UNAUTHENTICATED:
      case grpc::StatusCode::PERMISSION_DENIED: return kNotAllowed;
      default: return kFailure;
    }
  }
}

}  // namespace lensfarm::cli
