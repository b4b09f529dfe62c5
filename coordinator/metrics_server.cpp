#include "metrics_server.h"

#include <httplib.h>

#include <charconv>
#include <stdexcept>

#include "metrics.h"
#include "util/error.h"

namespace lensfarm {

MetricsServer::MetricsServer(const std::string& listen, std::function<std::string()> render)
    : server_(std::make_unique<httplib::Server>()) {
  const size_t colon = listen.rfind(':');
  int port = -1;
  if (colon != std::string::npos) {
    const char* first = listen.data() + colon + 1;
    const char* last = listen.data() + listen.size();
    if (auto [end, ec] = std::from_chars(first, last, port); ec != std::errc() || end != last) port = -1;
  }
  if (colon == std::string::npos || colon == 0 || port < 0 || port > 65535)
    throw InputError("--metrics-listen", "expected HOST:PORT, got \"" + listen + "\"");
  std::string host = listen.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);

  server_->new_task_queue = [] { return new httplib::ThreadPool(2); };  // scrapes are rare and small
  // SO_REUSEADDR but not httplib's default SO_REUSEPORT: a second process must not share the port.
  server_->set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  server_->Get("/metrics", [render = std::move(render)](const httplib::Request&, httplib::Response& response) {
    response.set_content(render(), kMetricsContentType);
  });
  if (port == 0)
    port = server_->bind_to_any_port(host);
  else if (!server_->bind_to_port(host, port))
    port = -1;
  if (port <= 0) throw std::runtime_error("cannot listen on " + listen + " for metrics");
  address_ = listen.substr(0, colon) + ":" + std::to_string(port);
  thread_ = std::thread([this] {
    server_->listen_after_bind();
    finished_ = true;
  });
  // listen_after_bind marks the server running first thing; stop() does nothing before that.
  while (!server_->is_running() && !finished_) std::this_thread::yield();
}

MetricsServer::~MetricsServer() {
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace lensfarm
