#include "proto/channel_security.h"
#include "common/util/file_contents.h"

#include <fstream>
#include <sstream>

#include "common/util/error.h"

namespace lensfarm {

namespace {
std::string readPem(const std::string& file, const char* flag) {
  return readWholeFileOrThrow(file, std::string(flag) + " " + file);
}
}  // namespace

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address, const ChannelSecurity& security,
                                           double maxBackoffSeconds, bool keepalive) {
  grpc::ChannelArguments args;
  // gRPC also uses the minimum reconnect backoff as the connect timeout of one attempt: at 100 ms
  // a TCP + HTTP/2 (+ TLS) handshake on a busy machine timed out ("connection attempt timed out
  // before receiving SETTINGS frame") and a client gave up on a healthy coordinator. One second
  // leaves handshakes room; the first retry still comes after 100 ms.
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 1000);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, int(maxBackoffSeconds * 1000));
  if (keepalive) {
    args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 5000);
    args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 5000);
    args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
    args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);  // the Attach stream carries no data
  }
  if (security.caFile.empty()) {
    if (!security.certFile.empty() || !security.keyFile.empty())
      throw InputError("--tls-cert", "a client certificate needs TLS: give --tls-ca too");
    return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
  }
  if (security.certFile.empty() != security.keyFile.empty())
    throw InputError(security.certFile.empty() ? "--tls-key" : "--tls-cert", "give both --tls-cert and --tls-key");
  grpc::SslCredentialsOptions tls;
  tls.pem_root_certs = readPem(security.caFile, "--tls-ca");
  if (!security.certFile.empty()) {
    tls.pem_cert_chain = readPem(security.certFile, "--tls-cert");
    tls.pem_private_key = readPem(security.keyFile, "--tls-key");
  }
  return grpc::CreateCustomChannel(address, grpc::SslCredentials(tls), args);
}

void authorize(grpc::ClientContext& context, const ChannelSecurity& security) {
  if (security.token) context.AddMetadata("authorization", "Bearer " + *security.token);
}

}  // namespace lensfarm
