#include "coordinator/rpc/auth.h"

#include <spdlog/spdlog.h>

#include "common/util/secret.h"

#include <optional>

namespace lensfarm {

namespace {

// The token of "authorization: Bearer <token>", or nullopt (no such metadata, or another scheme).
std::optional<std::string> bearerOf(const grpc::ServerContextBase* context, bool& present) {
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find("authorization");
  present = it != metadata.end();
  const std::string prefix = "Bearer ";
  if (!present) return std::nullopt;
  const std::string given(it->second.data(), it->second.size());
  if (given.rfind(prefix, 0) != 0) return std::nullopt;
  return given.substr(prefix.size());
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
  const std::optional<std::string> bearer = bearerOf(context, present);
  if (!bearer) return "";
  // Every credential compared, in constant time each: the time says nothing of which matched.
  std::string name;
  for (const WorkerCredential& c : *credentials_)
    if (equalSecrets(*bearer, c.token)) name = c.name;
  return name;
}

grpc::Status TokenGate::check(const grpc::ServerContextBase* context, const char* rpc) const {
  if (!enabled()) return grpc::Status::OK;
  bool present = false;
  const std::optional<std::string> bearer = bearerOf(context, present);
  if (bearer && token_ && equalSecrets(*bearer, *token_)) return grpc::Status::OK;
  if (bearer && !credentialOf(context).empty()) return grpc::Status::OK;
  if (const std::optional<User> user = userOf(context)) {
    if (user->role != User::Role::kViewer || readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
    refusals_->warn("read-only", fmt::format("refused {} from {}: {} is a viewer", rpc, context->peer(), user->name));
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        std::string(rpc) + ": " + user->name + " is a viewer: reading only");
  }
  if (bearer && readOnlyToken_ && equalSecrets(*bearer, *readOnlyToken_)) {
    if (readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
    refusals_->warn("read-only",
                    fmt::format("refused {} from {}: the {} token is read-only", rpc, context->peer(), readOnlyRole_));
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        std::string(rpc) + ": the " + readOnlyRole_ + " token is read-only");
  }
  const std::string roles = readOnlyToken_ ? role_ + " or " + readOnlyRole_ : role_;
  refusals_->warn("token", fmt::format("refused {} from {}: {} {} token", rpc, context->peer(),
                                       present ? "wrong" : "missing", roles));
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
