#include "coordinator/rpc/auth.h"

#include <spdlog/spdlog.h>

#include "common/util/secret.h"

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
  bool present = false;
  const std::optional<std::string> bearer = bearerOf(context, present);
  if (!bearer || users_->empty()) return std::nullopt;
  return userOfToken(*users_, *bearer);
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
  return checkBearer(bearer, present, rpc, context->peer());
}

grpc::Status TokenGate::checkAuthorization(const std::string& authorization, const char* rpc,
                                           const std::string& peer) const {
  return checkBearer(bearerOf(authorization), !authorization.empty(), rpc, peer);
}

grpc::Status TokenGate::checkBearer(const std::optional<std::string>& bearer, bool present, const char* rpc,
                                    const std::string& peer) const {
  if (!enabled()) return grpc::Status::OK;
  if (bearer && token_ && equalSecrets(*bearer, *token_)) return grpc::Status::OK;
  if (bearer && !credentialOfBearer(bearer).empty()) return grpc::Status::OK;
  if (const std::optional<User> user = bearer && !users_->empty() ? userOfToken(*users_, *bearer) : std::nullopt) {
    if (user->role != User::Role::kViewer || readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
    refusals_->warn("read-only", fmt::format("refused {} from {}: {} is a viewer", rpc, peer, user->name));
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        std::string(rpc) + ": " + user->name + " is a viewer: reading only");
  }
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
