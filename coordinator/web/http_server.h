#pragma once
// A cpp-httplib server on its own thread, listening on HOST:PORT (an IPv6 host in brackets; port
// 0 picks a free port), shared by the metrics endpoint (metrics_server.h) and the dashboard
// (dashboard_server.h). Routes are added by a callback before it starts listening. With HttpTls it
// serves HTTPS (cpp-httplib's SSLServer over OpenSSL) with the coordinator's own certificate.
#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace lensfarm {

// The PEM files of the coordinator's --tls-cert and --tls-key (the gRPC services' certificate),
// and with --tls-client-ca the CA whose client certificates are required (mutual TLS).
struct HttpTls {
  std::string certFile, keyFile, clientCaFile;
};

class HttpServer {
 public:
  // Throws InputError naming `flag` for a malformed address, InputError naming --tls-cert,
  // --tls-key or --tls-client-ca for a certificate OpenSSL refuses, and std::runtime_error
  // ("cannot listen on ADDRESS for WHAT") when it cannot listen. TLS 1.2 at least.
  HttpServer(const std::string& listen, const char* flag, const char* what, int threads,
             const std::function<void(httplib::Server&)>& routes, const std::optional<HttpTls>& tls = std::nullopt);
  ~HttpServer();  // stops serving
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // HOST:PORT actually listened on (the port resolved when 0 was asked for).
  const std::string& address() const { return address_; }
  // "https" or "http".
  const char* scheme() const { return tls_ ? "https" : "http"; }

 private:
  std::unique_ptr<httplib::Server> server_;
  bool tls_ = false;
  std::thread thread_;
  std::atomic<bool> finished_{false};
  std::string address_;
};

}  // namespace lensfarm
