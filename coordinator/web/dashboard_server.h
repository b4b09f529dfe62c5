#pragma once
// Serves the web dashboard over HTTP, or HTTPS with the coordinator's certificate (cpp-httplib,
// http_server.h): the page's assets (compiled into the binary, public: they hold no data) and the
// /api routes over Dashboard (dashboard.h), each of which needs "Authorization: Bearer <token>"
// when the coordinator has a client token: the client token for everything, the viewer token for
// the GET routes only (a POST with it is 403). The routes are listed in docs/dashboard.md.
#include <string>

#include "coordinator/web/dashboard.h"
#include "coordinator/web/http_server.h"

namespace lensfarm {

class DashboardServer {
 public:
  // Listens on `listen` (HOST:PORT; port 0 picks a free port), with TLS when `tls` is given.
  // Throws InputError for a malformed address or a certificate OpenSSL refuses and
  // std::runtime_error when it cannot listen.
  DashboardServer(const std::string& listen, Dashboard& dashboard, const std::optional<HttpTls>& tls = std::nullopt);

  const std::string& address() const { return server_.address(); }
  const char* scheme() const { return server_.scheme(); }

 private:
  HttpServer server_;
};

}  // namespace lensfarm
