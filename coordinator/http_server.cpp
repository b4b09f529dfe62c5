#include "http_server.h"

#include <httplib.h>

#include <charconv>
#include <stdexcept>

#include "util/error.h"

namespace lensfarm {

HttpServer::HttpServer(const std::string& listen, const char* flag, const char* what, int threads,
                       const std::function<void(httplib::Server&)>& routes)
    : server_(std::make_unique<httplib::Server>()) {
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
