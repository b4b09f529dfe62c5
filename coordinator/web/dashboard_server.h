#pragma once
// Serves the web dashboard over HTTP, or HTTPS with the coordinator's certificate (http_server.h,
// with its limits): the page's assets (compiled into the binary, public: they hold no data) and the
// /api routes over Dashboard (dashboard.h), each of which needs "Authorization: Bearer <token>"
// when the coordinator has a client token: the client token for everything, the viewer token for
// the GET routes only (a POST with it is 403). The routes are listed in docs/dashboard.md.
#include <string>
#include <string_view>

#include "common/util/throttled_log.h"

#include "coordinator/web/dashboard.h"
#include "coordinator/web/http_server.h"
#include "coordinator/web/rest_api.h"

namespace lensfarm {

// Whether a Host header names this machine by a loopback name or address, with or without a
// port: localhost, an IPv4 dotted quad in 127.0.0.0/8, or [::1]; nothing that merely begins so
// ("127.0.0.1.nip.io", "[::1]evil").
bool loopbackHost(std::string_view host);

class DashboardServer {
 public:
  // Listens on `listen` (HOST:PORT; port 0 picks a free port), with TLS when `tls` is given, and
  // serves the HTTP/JSON API's /api/v1 routes too when `api` is given. Throws InputError for a
  // malformed address or a certificate OpenSSL refuses and std::runtime_error when it cannot listen.
  DashboardServer(const std::string& listen, Dashboard& dashboard, RestApi* api = nullptr,
                  const std::optional<HttpTls>& tls = std::nullopt);

  const std::string& address() const { return server_.address(); }
  const char* scheme() const { return server_.scheme(); }

 private:
  ThrottledLog refusals_;  // refused tokens, logged at a bounded rate
  HttpServer server_;
};

}  // namespace lensfarm
