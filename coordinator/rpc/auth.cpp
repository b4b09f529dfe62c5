#include "coordinator/rpc/auth.h"

#include <spdlog/spdlog.h>

#include "common/util/secret.h"

#include <ctime>
#include <optional>

namespace lensfarm {

namespace {

// The token of an authorization value "Bearer <token>", or nullopt (another scheme).
std::optional<std::string> bearerOf(const std::string& given) {
  const std::string prefix = "Bearer ";
  if (given.rfind(prefix, 0) != 0) return std::nullopt;
  return given.substr(prefix.size());
}

// The same of a call's "authorization" metadata, or nullopt (none, or another scheme).
std::optional<std::string> bearerOf(const grpc::ServerContextBase* context, bool& present) {
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find("authorization");
  present = it != metadata.end();
  if (!present) return std::nullopt;
  return bearerOf(std::string(it->second.data(), it->second.size()));
}

}  // namespace

TokenGate TokenGate::withCredentials(std::vector<WorkerCredential> credentials) && {
  credentials_ = std::make_shared<const std::vector<WorkerCredential>>(std::move(credentials));
  return std::move(*this);
}

TokenGate TokenGate::withUsers(std::vector<User> users) && {
  users_ = std::make_shared<const std::vector<User>>(std::move(users));
  return std::move(*this);
}

std::optional<User> TokenGate::userOf(const grpc::ServerContextBase* context) const {
  if (users_->empty()) return std::nullopt;
  bool present = false;
  const std::optional<std::string> bearer = bearerOf(context, present);
  if (bearer) return userOfToken(*users_, *bearer);
  return present ? std::nullopt : certificateUserOf(context);
}

std::optional<User> TokenGate::certificateUserOf(const grpc::ServerContextBase* context) const {
  const std::shared_ptr<const grpc::AuthContext> auth = context->auth_context();
  if (!auth || !auth->IsPeerAuthenticated()) return std::nullopt;  // (mutual TLS verified the certificate)
  for (const grpc::string_ref& name : auth->FindPropertyValues(GRPC_X509_CN_PROPERTY_NAME))
    if (std::optional<User> user = userOfCertificate(*users_, std::string(name.data(), name.size()))) return user;
  return std::nullopt;
}

std::string TokenGate::credentialOf(const grpc::ServerContextBase* context) const {
  bool present = false;
  return credentialOfBearer(bearerOf(context, present));
}

std::string TokenGate::credentialOfBearer(const std::optional<std::string>& bearer) const {
  if (!bearer) return "";
  // Every credential compared, in constant time each: the time says nothing of which matched.
  std::string name;
  for (const WorkerCredential& c : *credentials_)
    if (equalSecrets(*bearer, c.token)) name = c.name;
  return name;
}

grpc::Status TokenGate::check(const grpc::ServerContextBase* context, const char* rpc) const {
  bool present = false;
  const std::optional<std::string> bearer = bearerOf(context, present);
  // No token: a person known by their client certificate (users.h), if any.
  if (!present && !users_->empty())
    if (const std::optional<User> user = certificateUserOf(context)) return checkUser(*user, rpc, context->peer());
  return checkBearer(bearer, present, rpc, context->peer());
}

grpc::Status TokenGate::checkAuthorization(const std::string& authorization, const char* rpc,
                                           const std::string& peer) const {
  return checkBearer(bearerOf(authorization), !authorization.empty(), rpc, peer);
}

grpc::Status TokenGate::checkUser(const User& user, const char* rpc, const std::string& peer) const {
  const char* what = user.certificateName.empty() ? "token" : "identity";
  if (user.expired(int64_t(std::time(nullptr)))) {
    refusals_->warn("expired", fmt::format("refused {} from {}: the {} of {} expired at {}", rpc, peer, what, user.name,
                                           user.expiryText()));
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        std::string(rpc) + ": the " + what + " of " + user.name + " expired at " + user.expiryText());
  }
  if (user.role != User::Role::kViewer || readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
  refusals_->warn("read-only", fmt::format("refused {} from {}: {} is a viewer", rpc, peer, user.name));
  return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                      std::string(rpc) + ": " + user.name + " is a viewer: reading only");
}

grpc::Status TokenGate::checkBearer(const std::optional<std::string>& bearer, bool present, const char* rpc,
                                    const std::string& peer) const {
  if (!enabled()) return grpc::Status::OK;
  if (bearer && token_ && equalSecrets(*bearer, *token_)) return grpc::Status::OK;
  if (bearer && !credentialOfBearer(bearer).empty()) return grpc::Status::OK;
  if (const std::optional<User> user = bearer && !users_->empty() ? userOfToken(*users_, *bearer) : std::nullopt)
    return checkUser(*user, rpc, peer);
  if (bearer && readOnlyToken_ && equalSecrets(*bearer, *readOnlyToken_)) {
    if (readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
    refusals_->warn("read-only",
                    fmt::format("refused {} from {}: the {} token is read-only", rpc, peer, readOnlyRole_));
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        std::string(rpc) + ": the " + readOnlyRole_ + " token is read-only");
  }
  const std::string roles = readOnlyToken_ ? role_ + " or " + readOnlyRole_ : role_;
  refusals_->warn("token",
                  fmt::format("refused {} from {}: {} {} token", rpc, peer, present ? "wrong" : "missing", roles));
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                      std::string(rpc) + ": " + (present ? "wrong " : "missing ") + roles + " token");
}

std::string TokenGate::roleOf(const grpc::ServerContextBase* context) const {
  if (!enabled()) return "anyone";
  bool present = false;
  const std::optional<std::string> bearer = bearerOf(context, present);
  if (bearer && readOnlyToken_ && equalSecrets(*bearer, *readOnlyToken_)) return readOnlyRole_;
  if (const std::optional<User> user = userOf(context)) return roleName(user->role);
  return role_;
}

}  // namespace lensfarm
