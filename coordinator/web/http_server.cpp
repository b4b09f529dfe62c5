#include "coordinator/web/http_server.h"

#include <httplib.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

#include <charconv>
#include <stdexcept>

#include "common/util/error.h"

namespace lensfarm {

namespace {

// OpenSSL's queued errors as one line (and the queue emptied).
std::string opensslErrors() {
  std::string out;
  while (const unsigned long code = ERR_get_error()) {
    char text[256];
    ERR_error_string_n(code, text, sizeof text);
    out += (out.empty() ? "" : "; ") + std::string(text);
  }
  return out.empty() ? "unknown OpenSSL error" : out;
}

// An SSLServer set up from the PEM files, or InputError naming the flag whose file OpenSSL refused.
std::unique_ptr<httplib::Server> tlsServer(const HttpTls& tls) {
  std::optional<InputError> error;
  const auto refuse = [&](const char* flag, const std::string& file, const std::string& what) {
    error.emplace(flag, file + ": " + what + " (" + opensslErrors() + ")");
    return false;
  };
  ERR_clear_error();
  auto server = std::make_unique<httplib::SSLServer>([&](SSL_CTX& ctx) {
    SSL_CTX_set_min_proto_version(&ctx, TLS1_2_VERSION);
    SSL_CTX_set_options(&ctx, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION);
    if (SSL_CTX_use_certificate_chain_file(&ctx, tls.certFile.c_str()) != 1)
      return refuse("--tls-cert", tls.certFile, "not a PEM certificate chain");
    if (SSL_CTX_use_PrivateKey_file(&ctx, tls.keyFile.c_str(), SSL_FILETYPE_PEM) != 1)
      return refuse("--tls-key", tls.keyFile, "not a PEM private key");
    if (SSL_CTX_check_private_key(&ctx) != 1) return refuse("--tls-key", tls.keyFile, "not the key of --tls-cert");
    if (!tls.clientCaFile.empty()) {
      STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(tls.clientCaFile.c_str());
      if (SSL_CTX_load_verify_locations(&ctx, tls.clientCaFile.c_str(), nullptr) != 1 || names == nullptr) {
        if (names) sk_X509_NAME_pop_free(names, X509_NAME_free);
        return refuse("--tls-client-ca", tls.clientCaFile, "not a PEM CA certificate");
      }
      SSL_CTX_set_client_CA_list(&ctx, names);  // takes ownership
      SSL_CTX_set_verify(&ctx, SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT, nullptr);
    }
    return true;
  });
  if (error) throw *error;
  if (!server->is_valid()) throw std::runtime_error("cannot set up TLS: " + opensslErrors());
  return server;
}

}  // namespace

HttpServer::HttpServer(const std::string& listen, const char* flag, const char* what, int threads,
                       const std::function<void(httplib::Server&)>& routes, const std::optional<HttpTls>& tls)
    : tls_(tls.has_value()) {
  const size_t colon = listen.rfind(':');
  int port = -1;
  if (colon != std::string::npos) {
    const char* first = listen.data() + colon + 1;
    const char* last = listen.data() + listen.size();
    if (auto [end, ec] = std::from_chars(first, last, port); ec != std::errc() || end != last) port = -1;
  }
  if (colon == std::string::npos || colon == 0 || port < 0 || port > 65535)
    throw InputError(flag, "expected HOST:PORT, got \"" + listen + "\"");
  std::string host = listen.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  server_ = tls ? tlsServer(*tls) : std::make_unique<httplib::Server>();

  const size_t poolSize = size_t(std::max(1, threads));
  server_->new_task_queue = [poolSize] { return new httplib::ThreadPool(poolSize); };
  // SO_REUSEADDR but not httplib's default SO_REUSEPORT: a second process must not share the port.
  server_->set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  routes(*server_);
  if (port == 0)
    port = server_->bind_to_any_port(host);
  else if (!server_->bind_to_port(host, port))
    port = -1;
  if (port <= 0) throw std::runtime_error("cannot listen on " + listen + " for " + what);
  address_ = listen.substr(0, colon) + ":" + std::to_string(port);
  thread_ = std::thread([this] {
    server_->listen_after_bind();
    finished_ = true;
  });
  // listen_after_bind marks the server running first thing; stop() does nothing before that.
  while (!server_->is_running() && !finished_) std::this_thread::yield();
}

HttpServer::~HttpServer() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace lensfarm
