#pragma once
// The coordinator's HTTP/1.1 servers, shared by the metrics endpoint (metrics_server.h) and the
// dashboard (dashboard_server.h), on Boost.Beast. One I/O thread reads and writes every connection
// asynchronously and a small pool runs the handlers, so a slow or hostile client holds a socket
// and a bounded buffer, never a thread.
//
// Every request is bounded before it is read further (HttpLimits; the figures in docs/farm.md,
// "Security"): the request line and header fields by bytes and count (431), the whole header by a
// deadline counted from the first byte waited for, not per read (408: a slowloris client sending
// a byte a second is cut off as surely as a silent one), the body by its declared or chunked size
// (413, answered from the header, before one byte of the body is read) and by a deadline. A
// route's guard (the dashboard's token check) runs on the header alone, so a refused request's
// body is never read either. Framing is strict: conflicting Content-Length and Transfer-Encoding,
// or two different Content-Lengths, are 400. Connections are capped; at the cap, the oldest one
// still waiting for its header is closed to make room (a flood of idle connections cannot lock out
// a legitimate client), and if every connection is busy the new one is closed.
//
// Every response carries the anti-framing, no-sniff and no-referrer headers, and over TLS HSTS.
// With HttpTls it serves HTTPS with the coordinator's certificate: TLS 1.3, or TLS 1.2 with
// forward-secret AEAD suites only (ECDHE with AES-GCM or ChaCha20-Poly1305).
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lensfarm {

// The PEM files of the coordinator's --tls-cert and --tls-key (the gRPC services' certificate),
// and with --tls-client-ca the CA whose client certificates are required (mutual TLS).
struct HttpTls {
  std::string certFile, keyFile, clientCaFile;
};

struct HttpLimits {
  size_t maxHeaderBytes = 16 * 1024;  // the request line and all fields
  size_t maxHeaderFields = 100;
  size_t maxBodyBytes = 64 * 1024;
  std::chrono::milliseconds headerDeadline{10'000};  // also how long an idle keep-alive connection stays
  std::chrono::milliseconds bodyDeadline{30'000};
  // A response must be written within this, plus one second per MiB of body.
  std::chrono::milliseconds writeDeadline{60'000};
  size_t maxConnections = 256;
  int handlerThreads = 4;
};

struct HttpRequest {
  std::string method, target, path, body;
  std::string remoteAddress;
  std::vector<std::string> matches;                                 // the route's regex groups; [0] is the whole path
  std::vector<std::pair<std::string, std::string>> headers, query;  // query: percent-decoded

  // The first header (case-insensitive name) or the query parameter named so; "" if none.
  std::string header(std::string_view name) const;
  bool hasParam(std::string_view name) const;
  std::string param(std::string_view name) const;
};

// A response body written as it comes (Server-Sent Events): after the header, `next` runs on the
// handler pool again and again and returns the bytes to send next, "" when there are none yet
// (asked again after `pollInterval`), or nullopt to end the response. The connection closes at
// the end or when a write fails or misses its deadline (a reader gone).
struct HttpStream {
  std::function<std::optional<std::string>()> next;
  std::chrono::milliseconds pollInterval{250};
};

struct HttpResponse {
  int status = 200;
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  std::shared_ptr<HttpStream> stream;  // set: `body` is ignored and the stream is sent instead

  void setContent(std::string content, std::string contentType);
  void setHeader(std::string name, std::string value);
};

// Answers a request; exceptions it throws are answered 500 (without their text).
using HttpHandler = std::function<void(const HttpRequest&, HttpResponse&)>;
// Runs on the header alone (request.body empty): returns true, with `response` filled, to answer
// without reading the body or calling the handler.
using HttpGuard = std::function<bool(const HttpRequest&, HttpResponse&)>;

// A server's routes: METHOD and a regex the whole path must match (its groups become
// HttpRequest::matches). First match wins; a path matched only by another method is 405.
class HttpRoutes {
 public:
  struct Route {
    std::string method;
    std::regex pattern;
    HttpHandler handler;
    HttpGuard guard;
    size_t maxBodyBytes = 0;  // 0: HttpLimits::maxBodyBytes
  };
  void get(const std::string& pattern, HttpHandler handler, HttpGuard guard = nullptr);
  void post(const std::string& pattern, HttpHandler handler, HttpGuard guard = nullptr);
  // Any method; `maxBodyBytes` (0: the server's limit) for routes that take large bodies, whose
  // body deadline then grows by a second per MiB.
  void add(std::string method, const std::string& pattern, HttpHandler handler, HttpGuard guard = nullptr,
           size_t maxBodyBytes = 0);

  // The route for METHOD PATH (its groups in `matches`), or null; `pathKnown` tells whether
  // another method's route matches the path.
  const Route* match(const std::string& method, const std::string& path, std::vector<std::string>& matches,
                     bool& pathKnown) const;

 private:
  std::vector<Route> routes_;
};

class HttpServer {
 public:
  // Listens on HOST:PORT (an IPv6 host in brackets; port 0 picks a free port). Throws InputError
  // naming `flag` for a malformed address, InputError naming --tls-cert, --tls-key or
  // --tls-client-ca for a certificate OpenSSL refuses, and std::runtime_error ("cannot listen on
  // ADDRESS for WHAT") when it cannot listen.
  HttpServer(const std::string& listen, const char* flag, const char* what, HttpRoutes routes,
             const HttpLimits& limits = {}, const std::optional<HttpTls>& tls = std::nullopt);
  ~HttpServer();  // stops serving: closes every connection, waits for running handlers
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // HOST:PORT actually listened on (the port resolved when 0 was asked for).
  const std::string& address() const;
  // "https" or "http".
  const char* scheme() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lensfarm
