#pragma once
// How a process secures its gRPC connection to a coordinator: TLS (server verified against a CA,
// optionally a client certificate) and a bearer token sent as metadata with every call.
// Shared by the worker and the client; the coordinator's side is coordinator/rpc/auth.h.
#include <grpcpp/grpcpp.h>

#include <memory>
#include <optional>
#include <string>

namespace lensfarm {

struct ChannelSecurity {
  std::string caFile;                // PEM roots to verify the coordinator; empty: plain (insecure) gRPC
  std::string certFile;              // optional client certificate (PEM) for mutual TLS
  std::string keyFile;               // its private key
  std::optional<std::string> token;  // sent as "authorization: Bearer <token>"
};

// A channel whose reconnect backoff stays short (at most `maxBackoffSeconds`), so a worker or
// client notices a restarted coordinator within seconds. With `keepalive` (workers), HTTP/2 pings
// every 5 s, also with no call open, and a connection that does not answer within 5 s is dropped:
// a dead link is found in about 10 s (the coordinator of the same version accepts such pings).
// Throws InputError naming an unreadable certificate file.
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address, const ChannelSecurity& security,
                                           double maxBackoffSeconds = 5.0, bool keepalive = false);

// Adds the token (if any) to a call.
void authorize(grpc::ClientContext& context, const ChannelSecurity& security);

}  // namespace lensfarm
