#include "auth.h"

#include <spdlog/spdlog.h>

#include "util/secret.h"

namespace lensfarm {

grpc::Status TokenGate::check(const grpc::ServerContextBase* context, const char* rpc) const {
  if (!token_) return grpc::Status::OK;
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find("authorization");
  const std::string prefix = "Bearer ";
  const bool present = it != metadata.end();
  const std::string given = present ? std::string(it->second.data(), it->second.size()) : "";
  if (present && given.rfind(prefix, 0) == 0 && equalSecrets(given.substr(prefix.size()), *token_))
    return grpc::Status::OK;
  spdlog::warn("refused {} from {}: {} {} token", rpc, context->peer(), present ? "wrong" : "missing", role_);
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                      std::string(rpc) + ": " + (present ? "wrong " : "missing ") + role_ + " token");
}

}  // namespace lensfarm
