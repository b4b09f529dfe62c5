#pragma once
// How the farm commands reach the coordinator: --coordinator (LENSFARM_COORDINATOR), the client
// token and TLS flags, and the mapping of the coordinator's gRPC statuses to exit codes
// (client/exit_codes.h, docs/cli.md).
#include <CLI/CLI.hpp>
#include <functional>
#include <string>

#include "common/util/secret.h"
#include "proto/channel_security.h"

namespace lensfarm::cli {

struct Connection {
  std::string coordinator = "127.0.0.1:7878";
  std::string tokenFile;
  ChannelSecurity security;

  // The connection's security with the token read (InputError naming a bad token file).
  ChannelSecurity resolved() const {
    ChannelSecurity s = security;
    s.token = readToken(tokenFile, "LENSFARM_TOKEN");
    return s;
  }
};

// Adds --coordinator, --token-file and the TLS flags to `cmd`.
void addCoordinatorOption(CLI::App* cmd, Connection& c);

// The arguments of a command about one job: the connection and the job id.
struct JobArgs {
  Connection c;
  std::string job;
};

void addJobArgs(CLI::App* cmd, JobArgs& f);

// Runs a farm command, turning the coordinator's answers into exit codes.
int guardedCall(const std::function<int()>& body);

}  // namespace lensfarm::cli
