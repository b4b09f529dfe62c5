#pragma once
// Token authentication for the coordinator's services: each service has its own token (clients
// and workers never share one), checked against the "authorization: Bearer <token>" metadata of
// every call. A missing or wrong token gets UNAUTHENTICATED and a log line naming the peer, never
// the token.
#include <grpcpp/grpcpp.h>

#include <optional>
#include <string>

namespace lensfarm {

class TokenGate {
 public:
  // No token: every call passes (only allowed on loopback, see main.cpp).
  TokenGate(std::optional<std::string> token, std::string role) : token_(std::move(token)), role_(std::move(role)) {}
  grpc::Status check(const grpc::ServerContextBase* context, const char* rpc) const;
  bool enabled() const { return token_.has_value(); }

 private:
  std::optional<std::string> token_;
  std::string role_;
};

}  // namespace lensfarm
