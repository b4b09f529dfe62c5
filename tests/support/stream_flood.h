#pragma once
// Many server streams opened at once, each reading its first message and then nothing more, as a
// hostile or stalled client would: how many the server holds open and how many it ends at once
// (and with what), for the flood tests of per-role stream caps (WatchJob, Download).
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace lensfarm::test {

template <class Message>
class StreamFlood {
 public:
  // Prepares one call on `context` and `queue` (e.g. stub->PrepareAsyncWatchJob); the flood starts it.
  using Prepare = std::function<std::unique_ptr<grpc::ClientAsyncReader<Message>>(
      size_t index, grpc::ClientContext& context, grpc::CompletionQueue& queue)>;

  struct Counts {
    size_t held = 0;      // the first message came; the stream stays open
    size_t refused = 0;   // ended with RESOURCE_EXHAUSTED
    size_t other = 0;     // ended otherwise
    size_t pending = 0;   // neither, by the deadline
    std::string refusal;  // one RESOURCE_EXHAUSTED message
  };

  StreamFlood(size_t streams, const Prepare& prepare) {
    for (size_t k = 0; k < streams; ++k) {  // tags: 3k started, 3k+1 first message, 3k+2 finished
      auto s = std::make_unique<Stream>();
      s->reader = prepare(k, s->context, queue_);
      s->reader->StartCall(tag(k, 0));
      streams_.push_back(std::move(s));
    }
  }
  StreamFlood(const StreamFlood&) = delete;
  StreamFlood& operator=(const StreamFlood&) = delete;
  ~StreamFlood() { cancel(); }

  // Waits until every stream has its first message or has ended, or `timeout` passes.
  Counts settle(std::chrono::seconds timeout) {
    Counts c;
    c.pending = streams_.size();
    const auto deadline = std::chrono::system_clock::now() + timeout;
    while (c.pending > 0) {
      void* t = nullptr;
      bool ok = false;
      if (queue_.AsyncNext(&t, &ok, deadline) != grpc::CompletionQueue::NextStatus::GOT_EVENT) break;
      const size_t k = reinterpret_cast<size_t>(t) / 3, step = reinterpret_cast<size_t>(t) % 3;
      Stream& s = *streams_[k];
      if (step == 0) {
        s.reader->Read(&s.first, tag(k, 1));
      } else if (step == 1 && ok) {
        ++c.held;
        --c.pending;
      } else if (step == 1) {
        s.reader->Finish(&s.end, tag(k, 2));
      } else {
        if (s.end.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
          ++c.refused;
          c.refusal = s.end.error_message();
        } else {
          ++c.other;
        }
        --c.pending;
      }
    }
    return c;
  }

  // Cancels every stream and waits for the queue to drain (their server slots are then returned).
  void cancel() {
    if (cancelled_) return;
    cancelled_ = true;
    for (auto& s : streams_) s->context.TryCancel();
    queue_.Shutdown();
    void* t = nullptr;
    bool ok = false;
    while (queue_.Next(&t, &ok)) {
      const size_t k = reinterpret_cast<size_t>(t) / 3, step = reinterpret_cast<size_t>(t) % 3;
      if (step == 1) streams_[k]->reader->Finish(&streams_[k]->end, tag(k, 2));
    }
  }

 private:
  struct Stream {
    grpc::ClientContext context;
    Message first;
    grpc::Status end;
    std::unique_ptr<grpc::ClientAsyncReader<Message>> reader;
  };
  static void* tag(size_t k, size_t step) { return reinterpret_cast<void*>(3 * k + step); }

  grpc::CompletionQueue queue_;
  std::vector<std::unique_ptr<Stream>> streams_;
  bool cancelled_ = false;
};

}  // namespace lensfarm::test
