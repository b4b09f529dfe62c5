#pragma once
// Serves the coordinator's metrics (metrics.h) over HTTP for Prometheus: GET /metrics. A thin
// shell over cpp-httplib; the text comes from a callback, so the server knows nothing of jobs.
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace lensfarm {

class MetricsServer {
 public:
  // Listens on `listen` (HOST:PORT, an IPv6 host in brackets; port 0 picks a free port) and
  // answers GET /metrics with render()'s text. Throws InputError for a malformed address and
  // std::runtime_error when it cannot listen.
  MetricsServer(const std::string& listen, std::function<std::string()> render);
  ~MetricsServer();  // stops serving
  MetricsServer(const MetricsServer&) = delete;
  MetricsServer& operator=(const MetricsServer&) = delete;

  // HOST:PORT actually listened on (the port resolved when 0 was asked for).
  const std::string& address() const { return address_; }

 private:
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  std::atomic<bool> finished_{false};
  std::string address_;
};

}  // namespace lensfarm
