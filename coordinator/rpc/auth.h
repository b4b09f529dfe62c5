#pragma once
// Token authentication for the coordinator's services: each service has its own token (clients
// and workers never share one), checked against the "authorization: Bearer <token>" metadata of
// every call. A missing or wrong token gets UNAUTHENTICATED and a log line naming the peer, never
// the token (at a bounded rate: ThrottledLog). A service may also take a read-only token (the viewer's, on the client
// service) for the calls that only read: it gets PERMISSION_DENIED on any other. The worker
// service may also take per-machine credentials (worker_credentials.h): each is a token of the
// service's role, and credentialOf() says which one a call carries.
#include <grpcpp/grpcpp.h>

#include <memory>
#include <optional>
#include <set>
#include <string>

#include "common/util/throttled_log.h"
#include "coordinator/rpc/users.h"
#include "coordinator/rpc/worker_credentials.h"

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
  // Also the per-machine `credentials`, each a token of this gate's role. A gate with credentials
  // and no shared token takes only the credentials.
  TokenGate withCredentials(std::vector<WorkerCredential> credentials) &&;
  // Also the people of users.h, each with their own token and role (a viewer: the read-only RPCs
  // only). The shared token stays the administrators'.
  TokenGate withUsers(std::vector<User> users) &&;
  // The user a call carries the token of, or with no token the user its verified client
  // certificate names; nullopt otherwise (the shared token, another role's, none).
  std::optional<User> userOf(const grpc::ServerContextBase* context) const;
  grpc::Status check(const grpc::ServerContextBase* context, const char* rpc) const;
  // The same check of an HTTP request's Authorization value ("Bearer <token>"; "" when absent),
  // for the HTTP API to refuse a request before reading its body (rest_api.h).
  grpc::Status checkAuthorization(const std::string& authorization, const char* rpc, const std::string& peer) const;
  // The role of a call check() let through: the role of the token it carries, or "anyone" when
  // the service takes no token.
  std::string roleOf(const grpc::ServerContextBase* context) const;
  // The name of the credential a call carries; empty for the shared token, another role's or none.
  std::string credentialOf(const grpc::ServerContextBase* context) const;
  bool enabled() const { return token_.has_value() || !credentials_->empty() || !users_->empty(); }

 private:
  // A person's call: refused if their token or identity expired, or a viewer's call that writes.
  grpc::Status checkUser(const User& user, const char* rpc, const std::string& peer) const;
  // The person whose verified client certificate the call came with (users.h: cert=NAME).
  std::optional<User> certificateUserOf(const grpc::ServerContextBase* context) const;
  grpc::Status checkBearer(const std::optional<std::string>& bearer, bool present, const char* rpc,
                           const std::string& peer) const;
  std::string credentialOfBearer(const std::optional<std::string>& bearer) const;
  std::optional<std::string> token_;
  std::string role_;
  std::optional<std::string> readOnlyToken_;
  std::string readOnlyRole_;
  std::set<std::string> readOnlyRpcs_;
  std::shared_ptr<const std::vector<WorkerCredential>> credentials_ = std::make_shared<std::vector<WorkerCredential>>();
  std::shared_ptr<const std::vector<User>> users_ = std::make_shared<std::vector<User>>();
  std::shared_ptr<ThrottledLog> refusals_ = std::make_shared<ThrottledLog>();  // shared by copies
};

}  // namespace lensfarm
