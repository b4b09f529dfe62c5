#pragma once
// Token authentication for the coordinator's services: each service has its own token (clients
// and workers never share one), checked against the "authorization: Bearer <token>" metadata of
// every call. A missing or wrong token gets UNAUTHENTICATED and a log line naming the peer, never
// the token. A service may also take a read-only token (the viewer's, on the client service) for
// the calls that only read: it gets PERMISSION_DENIED on any other.
#include <grpcpp/grpcpp.h>

#include <optional>
#include <set>
#include <string>

namespace lensfarm {

class TokenGate {
 public:
  // No token: every call passes (only allowed on loopback, see main.cpp).
  TokenGate(std::optional<std::string> token, std::string role) : token_(std::move(token)), role_(std::move(role)) {}
  // Also `readOnlyToken` (role `readOnlyRole`) for the RPCs named in `readOnlyRpcs`.
  TokenGate(std::optional<std::string> token, std::string role, std::optional<std::string> readOnlyToken,
            std::string readOnlyRole, std::set<std::string> readOnlyRpcs)
      : token_(std::move(token)),
        role_(std::move(role)),
        readOnlyToken_(std::move(readOnlyToken)),
        readOnlyRole_(std::move(readOnlyRole)),
        readOnlyRpcs_(std::move(readOnlyRpcs)) {}
  grpc::Status check(const grpc::ServerContextBase* context, const char* rpc) const;
  bool enabled() const { return token_.has_value(); }

 private:
  std::optional<std::string> token_;
  std::string role_;
  std::optional<std::string> readOnlyToken_;
  std::string readOnlyRole_;
  std::set<std::string> readOnlyRpcs_;
};

}  // namespace lensfarm
