#include "coordinator/web/http_server.h"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <spdlog/spdlog.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <nlohmann/json.hpp>

#include <charconv>
#include <limits>
#include <list>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "common/util/error.h"
#include "common/util/log_text.h"

namespace lensfarm {

namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;
using boost::system::error_code;

std::string_view valueOf(const std::vector<std::pair<std::string, std::string>>& pairs, std::string_view name,
                         bool ignoreCase) {
  for (const auto& [key, value] : pairs)
    if (ignoreCase ? beast::iequals(key, beast::string_view(name.data(), name.size())) : key == name) return value;
  return {};
}

// application/x-www-form-urlencoded decoding of one query key or value ('+' is a space; a
// malformed escape is kept as written).
std::string percentDecoded(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    unsigned byte = 0;
    if (text[i] == '%' && i + 2 < text.size() &&
        std::from_chars(text.data() + i + 1, text.data() + i + 3, byte, 16).ptr == text.data() + i + 3) {
      out += char(byte);
      i += 2;
    } else {
      out += text[i] == '+' ? ' ' : text[i];
    }
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> queryOf(std::string_view query) {
  std::vector<std::pair<std::string, std::string>> out;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    if (pair.empty()) continue;
    const size_t eq = pair.find('=');
    out.emplace_back(percentDecoded(pair.substr(0, eq)),
                     eq == std::string_view::npos ? std::string() : percentDecoded(pair.substr(eq + 1)));
  }
  return out;
}

// OpenSSL's queued errors as one line (and the queue emptied).
std::string opensslErrors() {
  std::string out;
  while (const unsigned long code = ERR_get_error()) {
    char text[256];
    ERR_error_string_n(code, text, sizeof text);
    out += (out.empty() ? "" : "; ") + std::string(text);
  }
  return out.empty() ? "unknown OpenSSL error" : out;
}

// TLS 1.2 is limited to forward-secret AEAD suites; TLS 1.3's are all of that kind.
constexpr const char* kTls12Ciphers =
    "ECDHE-ECDSA-AES128-GCM-SHA256:ECDHE-RSA-AES128-GCM-SHA256:ECDHE-ECDSA-AES256-GCM-SHA384:"
    "ECDHE-RSA-AES256-GCM-SHA384:ECDHE-ECDSA-CHACHA20-POLY1305:ECDHE-RSA-CHACHA20-POLY1305";

// The server's TLS context from the PEM files, or InputError naming the flag whose file OpenSSL
// refused.
std::unique_ptr<ssl::context> makeTlsContext(const HttpTls& tls) {
  auto context = std::make_unique<ssl::context>(ssl::context::tls_server);
  SSL_CTX* ctx = context->native_handle();
  const auto refuse = [&](const char* flag, const std::string& file, const std::string& what) {
    return InputError(flag, file + ": " + what + " (" + opensslErrors() + ")");
  };
  ERR_clear_error();
  SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION);
  SSL_CTX_set_options(ctx, SSL_OP_NO_COMPRESSION | SSL_OP_NO_RENEGOTIATION | SSL_OP_CIPHER_SERVER_PREFERENCE);
  if (SSL_CTX_set_cipher_list(ctx, kTls12Ciphers) != 1)
    throw std::runtime_error("cannot set up TLS: " + opensslErrors());
  if (SSL_CTX_use_certificate_chain_file(ctx, tls.certFile.c_str()) != 1)
    throw refuse("--tls-cert", tls.certFile, "not a PEM certificate chain");
  if (SSL_CTX_use_PrivateKey_file(ctx, tls.keyFile.c_str(), SSL_FILETYPE_PEM) != 1)
    throw refuse("--tls-key", tls.keyFile, "not a PEM private key");
  if (SSL_CTX_check_private_key(ctx) != 1) throw refuse("--tls-key", tls.keyFile, "not the key of --tls-cert");
  if (!tls.clientCaFile.empty()) {
    STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(tls.clientCaFile.c_str());
    if (SSL_CTX_load_verify_locations(ctx, tls.clientCaFile.c_str(), nullptr) != 1 || names == nullptr) {
      if (names) sk_X509_NAME_pop_free(names, X509_NAME_free);
      throw refuse("--tls-client-ca", tls.clientCaFile, "not a PEM CA certificate");
    }
    SSL_CTX_set_client_CA_list(ctx, names);  // takes ownership
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT, nullptr);
  }
  return context;
}

// HOST and PORT of HOST:PORT (brackets of an IPv6 host removed), or InputError naming `flag`.
std::pair<std::string, int> hostAndPort(const std::string& listen, const char* flag) {
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
  return {host, port};
}

// A connection the accept loop may close to make room (one waiting for its header).
class Connection {
 public:
  virtual ~Connection() = default;
  virtual void evict() = 0;
};

// What the accept loop and every connection share; connections hold it, so it outlives them.
struct Shared {
  Shared(HttpRoutes routes_, const HttpLimits& limits_, bool tls_, asio::thread_pool& handlers_)
      : routes(std::move(routes_)), limits(limits_), tls(tls_), handlers(handlers_) {}
  HttpRoutes routes;
  HttpLimits limits;
  bool tls = false;
  asio::thread_pool& handlers;
  std::mutex mutex;                              // guards the two below
  std::list<std::weak_ptr<Connection>> waiting;  // waiting for a header, oldest first
  size_t connections = 0;
};

using Message = http::response<http::string_body>;

// Headers every response carries: no framing by another site, no content sniffing, no Referer to
// other origins, and a page that loads only its own scripts, styles and images (and blob: images).
template <class Header>
void addSafetyHeaders(Header& message, bool tls) {
  message.set("X-Frame-Options", "DENY");
  message.set("Content-Security-Policy",
              "default-src 'self'; img-src 'self' blob: data:; connect-src 'self' blob:; object-src 'none'; "
              "base-uri 'none'; "
              "form-action 'self'; frame-ancestors 'none'");
  message.set("X-Content-Type-Options", "nosniff");
  message.set("Referrer-Policy", "no-referrer");
  if (tls) message.set("Strict-Transport-Security", "max-age=31536000");
}

HttpResponse errorResponse(int status, const std::string& message) {
  HttpResponse response;
  response.status = status;
  response.setContent(nlohmann::json{{"error", message}}.dump(), "application/json");
  return response;
}

// One connection's life: [TLS handshake], then per request: header (deadline, limits), route,
// guard, body (deadline, limit), handler (on the pool), response (deadline); keep-alive loops.
template <class Stream>
class Session final : public Connection, public std::enable_shared_from_this<Session<Stream>> {
  static constexpr bool kTls = !std::is_same_v<Stream, beast::tcp_stream>;

 public:
  Session(Stream stream, std::shared_ptr<Shared> shared)
      : stream_(std::move(stream)),
        shared_(std::move(shared)),
        limits_(shared_->limits),
        timer_(stream_.get_executor()),
        buffer_(std::max<size_t>(limits_.maxHeaderBytes, 8192) + 65536) {}

  ~Session() override {
    std::lock_guard lock(shared_->mutex);
    if (waitingAt_) shared_->waiting.erase(*waitingAt_);
    --shared_->connections;
  }

  void start() {
    error_code ec;
    const auto peer = beast::get_lowest_layer(stream_).socket().remote_endpoint(ec);
    remote_ = ec ? "?" : peer.address().to_string();
    if constexpr (kTls) {
      setWaiting(true);
      armDeadline(limits_.headerDeadline);
      stream_.async_handshake(ssl::stream_base::server, [self = this->shared_from_this()](error_code error) {
        self->disarm();
        if (error) return self->close();
        self->readHeader();
      });
    } else {
      readHeader();
    }
  }

  void evict() override {
    setWaiting(false);
    evicted_ = true;
    close();
  }

 private:
  void setWaiting(bool waiting) {
    std::lock_guard lock(shared_->mutex);
    if (waiting && !waitingAt_) {
      waitingAt_ = shared_->waiting.insert(shared_->waiting.end(), this->weak_from_this());
    } else if (!waiting && waitingAt_) {
      shared_->waiting.erase(*waitingAt_);
      waitingAt_.reset();
    }
  }

  // A deadline for the operations started next: when it passes they are cancelled (not the
  // socket closed), so the completion handler can still answer 408.
  void armDeadline(std::chrono::milliseconds deadline) {
    timedOut_ = false;
    const uint64_t generation = ++generation_;
    timer_.expires_after(deadline);
    timer_.async_wait([weak = this->weak_from_this(), generation](error_code ec) {
      const auto self = weak.lock();
      if (ec || !self || self->generation_ != generation) return;
      self->timedOut_ = true;
      beast::get_lowest_layer(self->stream_).cancel();
    });
  }
  void disarm() {
    ++generation_;
    timer_.cancel();
  }

  void readHeader() {
    parser_.emplace();
    parser_->header_limit(uint32_t(std::min<size_t>(limits_.maxHeaderBytes, UINT32_MAX)));
    // Checked after the route and its guard, then set (not boost::none: Boost 1.74 compares a
    // Content-Length with an empty limit as if the limit were 0).
    parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
    setWaiting(true);
    armDeadline(limits_.headerDeadline);
    http::async_read_header(stream_, buffer_, *parser_, [self = this->shared_from_this()](error_code ec, size_t) {
      self->disarm();
      self->setWaiting(false);
      self->onHeader(ec);
    });
  }

  void onHeader(error_code ec) {
    if (ec) return refuseRead(ec, "header");
    const auto& header = parser_->get();
    request_ = HttpRequest{};
    request_.method = std::string(header.method_string());
    request_.target = std::string(header.target());
    const size_t question = request_.target.find('?');
    request_.path = request_.target.substr(0, question);
    if (question != std::string::npos) request_.query = queryOf(std::string_view(request_.target).substr(question + 1));
    request_.remoteAddress = remote_;
    for (const auto& field : header)
      request_.headers.emplace_back(std::string(field.name_string()), std::string(field.value()));
    if (request_.headers.size() > limits_.maxHeaderFields)
      return respond(errorResponse(431, "more than " + std::to_string(limits_.maxHeaderFields) + " header fields"),
                     true);
    bool pathKnown = false;
    route_ = shared_->routes.match(request_.method, request_.path, request_.matches, pathKnown);
    if (!route_)
      return respond(errorResponse(pathKnown ? 405 : 404, pathKnown ? "method not allowed" : "not found"),
                     closeAfterEarlyAnswer());
    if (route_->guard) {
      HttpResponse refused;
      if (route_->guard(request_, refused)) return respond(std::move(refused), closeAfterEarlyAnswer());
    }
    if (parser_->is_done()) return dispatch();
    if (const auto length = parser_->content_length(); length && *length > bodyLimit())
      return refuseRead(http::error::body_limit, "body");
    parser_->body_limit(bodyLimit());  // a chunked body is counted as it comes
    armDeadline(limits_.bodyDeadline + std::chrono::seconds(bodyLimit() >> 20));
    http::async_read(stream_, buffer_, *parser_, [self = this->shared_from_this()](error_code error, size_t) {
      self->disarm();
      if (error) return self->refuseRead(error, "body");
      self->dispatch();
    });
  }

  size_t bodyLimit() const { return route_ && route_->maxBodyBytes ? route_->maxBodyBytes : limits_.maxBodyBytes; }

  // Whether to close after answering from the header alone: the body, if any, is unread.
  bool closeAfterEarlyAnswer() const { return !parser_->is_done() || !parser_->get().keep_alive(); }

  // A read that failed: a limit or a deadline is answered (then the connection closed), a parse
  // error is 400, a closed or evicted connection just ends.
  void refuseRead(error_code ec, const char* part) {
    if (evicted_) return;
    if (timedOut_) {
      const auto seconds = std::chrono::duration<double>(part == std::string_view("header") ? limits_.headerDeadline
                                                                                            : limits_.bodyDeadline);
      if (part == std::string_view("header") && buffer_.size() == 0 && !parser_->got_some())
        return close();  // an idle keep-alive connection: nothing to answer
      return respond(errorResponse(408, std::string("the request ") + part + " did not arrive within " +
                                            fmt::format("{:g}", seconds.count()) + " s"),
                     true);
    }
    if (ec == http::error::header_limit)
      return respond(
          errorResponse(431, "request header larger than " + std::to_string(limits_.maxHeaderBytes) + " bytes"), true);
    if (ec == http::error::body_limit)
      return respond(errorResponse(413, "request body larger than " + std::to_string(bodyLimit()) + " bytes"), true);
    if (ec.category() == http::make_error_code(http::error::bad_method).category() &&
        ec != http::error::end_of_stream && ec != http::error::partial_message)
      return respond(errorResponse(400, "malformed request: " + ec.message()), true);
    close();
  }

  // Runs the handler on the pool and writes its response back on the I/O thread.
  void dispatch() {
    request_.body = std::move(parser_->get().body());
    const bool close = !parser_->get().keep_alive();
    asio::post(shared_->handlers, [self = this->shared_from_this(), close] {
      HttpResponse response;
      try {
        self->route_->handler(self->request_, response);
      } catch (const std::exception& e) {
        spdlog::error("http: {} {}: {}", self->request_.method, logText(self->request_.path), logText(e.what()));
        response = errorResponse(500, "internal error");
      }
      asio::post(self->stream_.get_executor(), [self, response = std::move(response), close]() mutable {
        self->respond(std::move(response), close);
      });
    });
  }

  void respond(HttpResponse response, bool close) {
    if (response.stream) return startStream(std::move(response));
    message_.emplace();
    Message& message = *message_;
    message.version(11);
    message.result(unsigned(response.status));
    addSafetyHeaders(message, kTls);
    for (const auto& [name, value] : response.headers) message.set(name, value);
    message.body() = std::move(response.body);
    message.keep_alive(!close);
    message.prepare_payload();
    armDeadline(limits_.writeDeadline + std::chrono::seconds(message.body().size() >> 20));
    http::async_write(stream_, message, [self = this->shared_from_this(), close](error_code ec, size_t) {
      self->disarm();
      self->message_.reset();
      if (ec || close) return self->lingeringClose(ec);
      self->readHeader();
    });
  }

  // A streamed response: the header (chunked, the connection closing at its end), then each piece
  // `next` gives as a chunk, polling while it has none.
  void startStream(HttpResponse response) {
    feed_ = std::move(response.stream);
    streamHeader_.emplace();
    auto& header = *streamHeader_;
    header.version(11);
    header.result(unsigned(response.status));
    addSafetyHeaders(header, kTls);
    for (const auto& [name, value] : response.headers) header.set(name, value);
    header.keep_alive(false);
    header.chunked(true);
    streamSerializer_.emplace(header);
    armDeadline(limits_.writeDeadline);
    http::async_write_header(stream_, *streamSerializer_, [self = this->shared_from_this()](error_code ec, size_t) {
      self->disarm();
      if (ec) return self->close();
      self->pump();
    });
  }
  void pump() {
    asio::post(shared_->handlers, [self = this->shared_from_this()] {
      std::optional<std::string> piece;
      bool failed = false;  // cut short: closed without the last chunk, so the reader knows
      try {
        piece = self->feed_->next();
      } catch (const std::exception& e) {
        failed = true;
        spdlog::warn("http: stream {}: {}", logText(self->request_.path), logText(e.what()));
      }
      asio::post(self->stream_.get_executor(), [self, failed, piece = std::move(piece)]() mutable {
        if (failed) return self->close();
        self->onPiece(std::move(piece));
      });
    });
  }
  void onPiece(std::optional<std::string> piece) {
    if (!piece) {
      armDeadline(limits_.writeDeadline);
      return asio::async_write(stream_, http::make_chunk_last(),
                               [self = this->shared_from_this()](error_code, size_t) { self->close(); });
    }
    if (piece->empty()) {
      pollTimer_.expires_after(feed_->pollInterval);
      return pollTimer_.async_wait([self = this->shared_from_this()](error_code ec) {
        if (!ec) self->pump();
      });
    }
    pending_ = std::move(*piece);
    armDeadline(limits_.writeDeadline);
    asio::async_write(stream_, http::make_chunk(asio::buffer(pending_)),
                      [self = this->shared_from_this()](error_code ec, size_t) {
                        self->disarm();
                        if (ec) return self->close();
                        self->pump();
                      });
  }

  // After an early answer (413, 431) the client may still be sending: stop writing, read and
  // drop what comes for a moment, so its TCP stack delivers the answer instead of a reset.
  void lingeringClose(error_code writeError) {
    if (writeError || kTls) return close();
    error_code ignored;
    beast::get_lowest_layer(stream_).socket().shutdown(tcp::socket::shutdown_send, ignored);
    armDeadline(std::chrono::milliseconds(2000));
    drain(0);
  }
  void drain(size_t drained) {
    auto scratch = std::make_shared<std::array<char, 16384>>();
    beast::get_lowest_layer(stream_).async_read_some(
        asio::buffer(*scratch), [self = this->shared_from_this(), scratch, drained](error_code ec, size_t n) {
          if (ec || drained + n > (1u << 20)) return self->close();
          self->drain(drained + n);
        });
  }

  void close() {
    disarm();
    pollTimer_.cancel();
    beast::get_lowest_layer(stream_).close();
  }

  Stream stream_;
  std::shared_ptr<Shared> shared_;
  const HttpLimits& limits_;
  asio::steady_timer timer_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::optional<Message> message_;
  // A streamed response (HttpStream): its source, header, serializer, the piece being written and
  // the timer between polls.
  std::shared_ptr<HttpStream> feed_;
  std::optional<http::response<http::empty_body>> streamHeader_;
  std::optional<http::response_serializer<http::empty_body>> streamSerializer_;
  std::string pending_;
  asio::steady_timer pollTimer_{stream_.get_executor()};
  HttpRequest request_;
  const HttpRoutes::Route* route_ = nullptr;
  std::string remote_;
  std::optional<std::list<std::weak_ptr<Connection>>::iterator> waitingAt_;
  uint64_t generation_ = 0;
  bool timedOut_ = false, evicted_ = false;
};

}  // namespace

std::string HttpRequest::header(std::string_view name) const { return std::string(valueOf(headers, name, true)); }
bool HttpRequest::hasParam(std::string_view name) const {
  return std::any_of(query.begin(), query.end(), [&](const auto& pair) { return pair.first == name; });
}
std::string HttpRequest::param(std::string_view name) const { return std::string(valueOf(query, name, false)); }

void HttpResponse::setContent(std::string content, std::string contentType) {
  body = std::move(content);
  setHeader("Content-Type", std::move(contentType));
}
void HttpResponse::setHeader(std::string name, std::string value) {
  for (auto& [key, existing] : headers)
    if (beast::iequals(key, beast::string_view(name.data(), name.size()))) {
      existing = std::move(value);
      return;
    }
  headers.emplace_back(std::move(name), std::move(value));
}

void HttpRoutes::get(const std::string& pattern, HttpHandler handler, HttpGuard guard) {
  add("GET", pattern, std::move(handler), std::move(guard));
}
void HttpRoutes::post(const std::string& pattern, HttpHandler handler, HttpGuard guard) {
  add("POST", pattern, std::move(handler), std::move(guard));
}
void HttpRoutes::add(std::string method, const std::string& pattern, HttpHandler handler, HttpGuard guard,
                     size_t maxBodyBytes) {
  routes_.push_back({std::move(method), std::regex(pattern), std::move(handler), std::move(guard), maxBodyBytes});
}

const HttpRoutes::Route* HttpRoutes::match(const std::string& method, const std::string& path,
                                           std::vector<std::string>& matches, bool& pathKnown) const {
  pathKnown = false;
  for (const Route& route : routes_) {
    std::smatch groups;
    if (!std::regex_match(path, groups, route.pattern)) continue;
    pathKnown = true;
    if (route.method != method) continue;
    matches.assign(groups.begin(), groups.end());
    return &route;
  }
  return nullptr;
}

struct HttpServer::Impl {
  Impl(HttpRoutes routes, const HttpLimits& limits, const std::optional<HttpTls>& tls)
      : tlsContext(tls ? makeTlsContext(*tls) : nullptr),
        io(1),
        handlers(size_t(std::max(1, limits.handlerThreads))),
        acceptor(io),
        shared(std::make_shared<Shared>(std::move(routes), limits, tls.has_value(), handlers)) {}

  void accept() {
    acceptor.async_accept([this](error_code ec, tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) admit(std::move(socket));
      accept();
    });
  }

  // Starts a session for the socket; at the cap, first closes the oldest connection still waiting
  // for its header, or refuses this one if none is.
  void admit(tcp::socket socket) {
    std::shared_ptr<Connection> evicted;
    {
      std::lock_guard lock(shared->mutex);
      if (shared->connections >= shared->limits.maxConnections) {
        while (!shared->waiting.empty() && !evicted) {
          evicted = shared->waiting.front().lock();
          if (!evicted) shared->waiting.pop_front();
        }
        if (!evicted) return;  // every connection is busy: this one is closed
      }
      ++shared->connections;
    }
    if (evicted) evicted->evict();
    if (tlsContext) {
      std::make_shared<Session<beast::ssl_stream<beast::tcp_stream>>>(
          beast::ssl_stream<beast::tcp_stream>(std::move(socket), *tlsContext), shared)
          ->start();
    } else {
      std::make_shared<Session<beast::tcp_stream>>(beast::tcp_stream(std::move(socket)), shared)->start();
    }
  }

  // Declared in destruction order's reverse: the I/O context outlives the pool's handlers (which
  // hold connections) and the TLS context outlives every connection.
  std::unique_ptr<ssl::context> tlsContext;
  asio::io_context io;
  asio::thread_pool handlers;
  tcp::acceptor acceptor;
  std::shared_ptr<Shared> shared;
  std::thread thread;
  std::string address;
};

HttpServer::HttpServer(const std::string& listen, const char* flag, const char* what, HttpRoutes routes,
                       const HttpLimits& limits, const std::optional<HttpTls>& tls) {
  auto [host, port] = hostAndPort(listen, flag);
  impl_ = std::make_unique<Impl>(std::move(routes), limits, tls);
  error_code ec;
  tcp::resolver resolver(impl_->io);
  const auto endpoints = resolver.resolve(host, std::to_string(port), tcp::resolver::passive, ec);
  if (ec || endpoints.empty())
    throw std::runtime_error("cannot listen on " + listen + " for " + what + ": " + (ec ? ec.message() : "no address"));
  const tcp::endpoint endpoint = endpoints.begin()->endpoint();
  // SO_REUSEADDR but not SO_REUSEPORT: a second process must not share the port.
  auto& acceptor = impl_->acceptor;
  if (acceptor.open(endpoint.protocol(), ec), !ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + listen + " for " + what + ": " + ec.message());
  impl_->address = listen.substr(0, listen.rfind(':')) + ":" + std::to_string(acceptor.local_endpoint().port());
  impl_->accept();
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
}

HttpServer::~HttpServer() {
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  error_code ignored;
  impl_->acceptor.close(ignored);
  impl_->handlers.join();
}

const std::string& HttpServer::address() const { return impl_->address; }
const char* HttpServer::scheme() const { return impl_->tlsContext ? "https" : "http"; }

}  // namespace lensfarm
