#include "coordinator/rpc/auth.h"

#include <spdlog/spdlog.h>

#include "common/util/secret.h"

namespace lensfarm {

grpc::Status TokenGate::check(const grpc::ServerContextBase* context, const char* rpc) const {
  if (!token_) return grpc::Status::OK;
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find("authorization");
  const std::string prefix = "Bearer ";
  const bool present = it != metadata.end();
  const std::string given = present ? std::string(it->second.data(), it->second.size()) : "";
  const bool bearer = present && given.rfind(prefix, 0) == 0;
  if (bearer && equalSecrets(given.substr(prefix.size()), *token_)) return grpc::Status::OK;
  if (bearer && readOnlyToken_ && equalSecrets(given.substr(prefix.size()), *readOnlyToken_)) {
    if (readOnlyRpcs_.count(rpc)) return grpc::Status::OK;
    spdlog::warn("refused {} from {}: the {} token is read-only", rpc, context->peer(), readOnlyRole_);
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        std::string(rpc) + ": the " + readOnlyRole_ + " token is read-only");
  }
  const std::string roles = readOnlyToken_ ? role_ + " or " + readOnlyRole_ : role_;
  spdlog::warn("refused {} from {}: {} {} token", rpc, context->peer(), present ? "wrong" : "missing", roles);
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                      std::string(rpc) + ": " + (present ? "wrong " : "missing ") + roles + " token");
}

}  // namespace lensfarm
