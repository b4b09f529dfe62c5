#pragma once
// Serves the web dashboard over HTTP (cpp-httplib, http_server.h): the page's assets (compiled
// into the binary, public) and the /api routes over Dashboard (dashboard.h), each of which needs
// "Authorization: Bearer <client token>" when the coordinator has a client token. The routes
// are listed in docs/dashboard.md.
#include <string>

#include "dashboard.h"
#include "http_server.h"

namespace lensfarm {

class DashboardServer {
 public:
  // Listens on `listen` (HOST:PORT; port 0 picks a free port). Throws InputError for a malformed
  // address and std::runtime_error when it cannot listen.
  DashboardServer(const std::string& listen, Dashboard& dashboard);

  const std::string& address() const { return server_.address(); }

 private:
  HttpServer server_;
};

}  // namespace lensfarm
