#pragma once
// Webhooks (docs/api.md "Webhooks"): the farm's events (event_feed.h) POSTed as JSON to the URLs
// a studio gives (--webhook), each signed, delivered at least once, in order per URL.
//
// A delivery is the FarmEvent in the HTTP API's JSON with these headers:
//   X-Lensfarm-Event: TYPE               e.g. job.done
//   X-Lensfarm-Delivery: SEQUENCE        the event's; the same on every retry (receivers dedupe by it)
//   X-Lensfarm-Signature: t=UNIX,v1=HEX  HEX = HMAC-SHA256(secret, "UNIX." + body), lowercase hex
// (the scheme of Stripe's and GitHub's webhooks: the timestamp inside the signature lets a
// receiver refuse a replayed old delivery). Any answer but 2xx, a refused connection or a timeout
// is retried after 1, 2, 4, ... s (at most maxRetrySeconds) up to `attempts` times, the URL's
// later events waiting behind it so order holds; then the event is given up with an error in the
// log. With a state dir the events and each URL's progress are kept, so a delivery pending when the
// coordinator stops is made after it restarts (at least once across restarts too).
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "coordinator/core/event_feed.h"

namespace lensfarm {

struct WebhookOptions {
  std::vector<std::string> urls;  // http:// or https:// (the system's CAs verify the server)
  std::set<std::string> types;    // the event types sent; empty: all
  std::string secret;             // the HMAC key
  int attempts = 8;
  double firstRetrySeconds = 1.0, maxRetrySeconds = 60.0;
  double timeoutSeconds = 10.0;  // to connect, send and be answered
  // Where each URL's progress is kept (the coordinator's state dir): the last event it has had,
  // read at start (nullopt: a URL new here, which starts with the events from now on) and
  // written after each event. Unset: from the feed's oldest event, kept nowhere.
  std::function<std::optional<uint64_t>(const std::string& url)> loadCursor;
  std::function<void(const std::string& url, uint64_t sequence)> saveCursor;
};

// "t=UNIX,v1=HEX" for `body` sent at `unixSeconds`.
std::string webhookSignature(const std::string& secret, int64_t unixSeconds, const std::string& body);

// Throws InputError naming --webhook for a URL it cannot send to (scheme, host, port) and naming
// --webhook-events for an unknown event type.
void checkWebhookOptions(const WebhookOptions& options);

class WebhookSender {
 public:
  // Starts one delivery thread per URL, from the feed's oldest event held.
  WebhookSender(const EventFeed& feed, WebhookOptions options);
  ~WebhookSender();  // stops (a delivery in progress ends at its timeout)
  WebhookSender(const WebhookSender&) = delete;
  WebhookSender& operator=(const WebhookSender&) = delete;

  // Counted since start, over every URL.
  uint64_t delivered() const { return delivered_; }
  uint64_t givenUp() const { return givenUp_; }

 private:
  void run(const std::string& url);
  // One POST; true when answered 2xx. `why`: what went wrong otherwise.
  bool post(const std::string& url, const FarmEvent& event, const std::string& body, std::string& why) const;
  bool waitUnlessStopping(double seconds);

  const EventFeed& feed_;
  WebhookOptions options_;
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;
  std::condition_variable stop_;
  std::atomic<uint64_t> delivered_{0}, givenUp_{0};
  std::vector<std::thread> threads_;
};

}  // namespace lensfarm
