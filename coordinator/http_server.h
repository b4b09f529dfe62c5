#pragma once
// A cpp-httplib server on its own thread, listening on HOST:PORT (an IPv6 host in brackets; port
// 0 picks a free port), shared by the metrics endpoint (metrics_server.h) and the dashboard
// (dashboard_server.h). Routes are added by a callback before it starts listening.
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace lensfarm {

class HttpServer {
 public:
  // Throws InputError naming `flag` for a malformed address and std::runtime_error ("cannot
  // listen on ADDRESS for WHAT") when it cannot listen.
  HttpServer(const std::string& listen, const char* flag, const char* what, int threads,
             const std::function<void(httplib::Server&)>& routes);
  ~HttpServer();  // stops serving
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // HOST:PORT actually listened on (the port resolved when 0 was asked for).
  const std::string& address() const { return address_; }

 private:
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  std::atomic<bool> finished_{false};
  std::string address_;
};

}  // namespace lensfarm
