#include "coordinator/web/webhooks.h"

#include <openssl/hmac.h>
#include <openssl/ssl.h>
#include <spdlog/spdlog.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/ssl/host_name_verification.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/farm/farm_types.h"
#include "common/util/error.h"
#include "common/util/log_text.h"
#include "common/util/version.h"
#include "coordinator/web/rest_api.h"
#include "proto/convert.h"

namespace lensfarm {

namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;

struct Url {
  bool tls = false;
  std::string host, port, target;
};

// http[s]://HOST[:PORT][/PATH]; nullopt for anything else (user info, a fragment, no host).
std::optional<Url> parseUrl(const std::string& text) {
  Url url;
  std::string rest;
  if (text.rfind("http://", 0) == 0) {
    rest = text.substr(7);
  } else if (text.rfind("https://", 0) == 0) {
    url.tls = true;
    rest = text.substr(8);
  } else {
    return std::nullopt;
  }
  const size_t slash = rest.find('/');
  std::string authority = rest.substr(0, slash);
  url.target = slash == std::string::npos ? "/" : rest.substr(slash);
  if (authority.empty() || authority.find('@') != std::string::npos || url.target.find('#') != std::string::npos ||
      url.target.find_first_of(" \r\n") != std::string::npos)
    return std::nullopt;
  const size_t colon = authority.rfind(':');
  const bool bracketed = authority.front() == '[';
  if (colon != std::string::npos && (!bracketed || colon > authority.find(']'))) {
    url.port = authority.substr(colon + 1);
    authority = authority.substr(0, colon);
    if (url.port.empty() || url.port.size() > 5 || url.port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(url.port) < 1 || std::stoi(url.port) > 65535)
      return std::nullopt;
  } else {
    url.port = url.tls ? "443" : "80";
  }
  if (bracketed) {
    if (authority.back() != ']') return std::nullopt;
    authority = authority.substr(1, authority.size() - 2);
  }
  url.host = authority;
  return url.host.empty() ? std::nullopt : std::optional<Url>(url);
}

// One HTTP exchange with a deadline over all of it: Asio's operations run on a private context for
// at most `timeout`, then are abandoned (the socket closed with the context).
class Exchange {
 public:
  Exchange(const Url& url, http::request<http::string_body> request, std::chrono::milliseconds timeout)
      : url_(url), request_(std::move(request)), timeout_(timeout) {}

  // The answer's status, or 0 with `why` set.
  unsigned run(std::string& why) {
    tcp::resolver resolver(io_);
    boost::system::error_code ec;
    const auto endpoints = resolver.resolve(url_.host, url_.port, ec);
    if (ec) return why = "cannot resolve " + url_.host + ": " + ec.message(), 0;
    unsigned status = 0;
    if (url_.tls) {
      ssl::context context(ssl::context::tls_client);
      context.set_default_verify_paths();
      context.set_verify_mode(ssl::verify_peer);
      context.set_verify_callback(ssl::host_name_verification(url_.host));
      beast::ssl_stream<beast::tcp_stream> stream(io_, context);
      SSL_set_tlsext_host_name(stream.native_handle(), url_.host.c_str());
      beast::get_lowest_layer(stream).expires_after(timeout_);
      beast::get_lowest_layer(stream).async_connect(endpoints, [&](auto error, auto) {
        if (error) return fail(error, "connect");
        stream.async_handshake(ssl::stream_base::client, [&](auto error2) {
          if (error2) return fail(error2, "TLS handshake");
          exchange(stream, status);
        });
      });
      io_.run();
    } else {
      beast::tcp_stream stream(io_);
      stream.expires_after(timeout_);
      stream.async_connect(endpoints, [&](auto error, auto) {
        if (error) return fail(error, "connect");
        exchange(stream, status);
      });
      io_.run();
    }
    why = why_;
    return status;
  }

 private:
  template <class Stream>
  void exchange(Stream& stream, unsigned& status) {
    http::async_write(stream, request_, [&](auto error, size_t) {
      if (error) return fail(error, "send");
      http::async_read(stream, buffer_, response_, [&](auto error2, size_t) {
        if (error2) return fail(error2, "read the answer");
        status = response_.result_int();
      });
    });
  }
  void fail(const boost::system::error_code& ec, const char* what) {
    why_ = std::string(what) + ": " + (ec == beast::error::timeout ? "timed out" : ec.message());
  }

  Url url_;
  http::request<http::string_body> request_;
  std::chrono::milliseconds timeout_;
  asio::io_context io_;
  beast::flat_buffer buffer_;
  http::response<http::string_body> response_;
  std::string why_;
};

}  // namespace

std::string webhookSignature(const std::string& secret, int64_t unixSeconds, const std::string& body) {
  const std::string signed_ = std::to_string(unixSeconds) + "." + body;
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned length = 0;
  HMAC(EVP_sha256(), secret.data(), int(secret.size()), reinterpret_cast<const unsigned char*>(signed_.data()),
       signed_.size(), mac, &length);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  for (unsigned i = 0; i < length; ++i) hex += {kHex[mac[i] >> 4], kHex[mac[i] & 15]};
  return "t=" + std::to_string(unixSeconds) + ",v1=" + hex;
}

void checkWebhookOptions(const WebhookOptions& options) {
  for (const std::string& url : options.urls)
    if (!parseUrl(url))
      throw InputError("--webhook", "\"" + url + "\": expected http://HOST[:PORT]/PATH or https://HOST[:PORT]/PATH");
  const auto& known = farm_event::allTypes();
  for (const std::string& type : options.types)
    if (std::find(known.begin(), known.end(), type) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      throw InputError("--webhook-events", "\"" + type + "\" is not an event type (" + list + ")");
    }
  if (!options.urls.empty() && options.secret.empty())
    throw InputError("--webhook-secret-file", "webhooks are signed: give the secret (or LENSFARM_WEBHOOK_SECRET)");
}

WebhookSender::WebhookSender(const EventFeed& feed, WebhookOptions options)
    : feed_(feed), options_(std::move(options)) {
  checkWebhookOptions(options_);
  for (const std::string& url : options_.urls) threads_.emplace_back([this, url] { run(url); });
}

WebhookSender::~WebhookSender() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  stop_.notify_all();
  for (std::thread& t : threads_) t.join();
}

bool WebhookSender::waitUnlessStopping(double seconds) {
  std::unique_lock lock(mutex_);
  return !stop_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return stopping_.load(); });
}

void WebhookSender::run(const std::string& url) {
  uint64_t cursor = 0;
  if (options_.loadCursor) {
    const std::optional<uint64_t> kept = options_.loadCursor(url);
    cursor = kept ? *kept : feed_.latest();
    // A URL new here starts now, and is kept from now: what it has not had by the next start is
    // delivered then.
    if (!kept && options_.saveCursor) options_.saveCursor(url, cursor);
  }
  while (!stopping_) {
    const std::vector<FarmEvent> events = feed_.after(cursor, 100, std::chrono::milliseconds(500));
    for (const FarmEvent& event : events) {
      if (stopping_) return;
      cursor = event.sequence;
      if (!options_.types.empty() && !options_.types.count(event.type)) {
        if (options_.saveCursor) options_.saveCursor(url, cursor);
        continue;
      }
      const std::string body = protoJson(proto::toProto(event));
      double wait = options_.firstRetrySeconds;
      for (int attempt = 1;; ++attempt) {
        std::string why;
        if (post(url, event, body, why)) {
          ++delivered_;
          if (options_.saveCursor) options_.saveCursor(url, cursor);
          spdlog::debug("webhook {}: {} {} delivered (attempt {})", logText(url), event.sequence, event.type, attempt);
          break;
        }
        if (attempt >= options_.attempts) {
          ++givenUp_;
          if (options_.saveCursor) options_.saveCursor(url, cursor);
          spdlog::error("webhook {}: event {} ({}) given up after {} attempts: {}", logText(url), event.sequence,
                        event.type, attempt, logText(why));
          break;
        }
        spdlog::warn("webhook {}: event {} ({}) attempt {} failed ({}); again in {:g} s", logText(url), event.sequence,
                     event.type, attempt, logText(why), wait);
        if (!waitUnlessStopping(wait)) return;
        wait = std::min(wait * 2, options_.maxRetrySeconds);
      }
    }
  }
}

bool WebhookSender::post(const std::string& target, const FarmEvent& event, const std::string& body,
                         std::string& why) const {
  const Url url = *parseUrl(target);
  const int64_t now =
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  http::request<http::string_body> request{http::verb::post, url.target, 11};
  request.set(http::field::host, url.host);
  request.set(http::field::user_agent, std::string("lensfarm-coordinator (") + kRendererVersion + ")");
  request.set(http::field::content_type, "application/json");
  request.set("X-Lensfarm-Event", event.type);
  request.set("X-Lensfarm-Delivery", std::to_string(event.sequence));
  request.set("X-Lensfarm-Signature", webhookSignature(options_.secret, now, body));
  request.keep_alive(false);
  request.body() = body;
  request.prepare_payload();
  Exchange exchange(url, std::move(request),
                    std::chrono::milliseconds(int64_t(1000 * std::max(0.1, options_.timeoutSeconds))));
  const unsigned status = exchange.run(why);
  if (status >= 200 && status < 300) return true;
  if (status != 0) why = "answered " + std::to_string(status);
  return false;
}

}  // namespace lensfarm
