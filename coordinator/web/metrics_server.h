#pragma once
// Serves the coordinator's metrics (metrics.h) over HTTP for Prometheus: GET /metrics. A thin
// shell over HttpServer (http_server.h); the text comes from a callback, so the server knows
// nothing of jobs.
#include <functional>
#include <string>

#include "coordinator/web/http_server.h"

namespace lensfarm {

class MetricsServer {
 public:
  // Listens on `listen` (HOST:PORT, an IPv6 host in brackets; port 0 picks a free port) and
  // answers GET /metrics with render()'s text. Throws InputError for a malformed address and
  // std::runtime_error when it cannot listen.
  MetricsServer(const std::string& listen, std::function<std::string()> render);

  // HOST:PORT actually listened on (the port resolved when 0 was asked for).
  const std::string& address() const { return server_.address(); }

 private:
  HttpServer server_;
};

}  // namespace lensfarm
