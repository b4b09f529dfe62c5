#include "coordinator/rpc/job_watchers.h"

#include <optional>

#include "coordinator/rpc/service.h"

namespace lensfarm {

namespace {
using Clock = std::chrono::steady_clock;
constexpr auto kPace = std::chrono::milliseconds(100);  // how often watched jobs are read
constexpr auto kLiveEvery = std::chrono::seconds(1);    // a status at least this often
}  // namespace

// One WatchJob stream. gRPC may run OnCancel beside OnWriteDone and the pump's offer, so the
// state they share is under ops_, no write starts after Finish, and Finish is called once.
class JobWatchers::Stream final : public grpc::ServerWriteReactor<v1::JobStatus> {
 public:
  Stream(JobWatchers& hub, std::string jobId, std::string role)
      : hub_(hub), jobId_(std::move(jobId)), role_(std::move(role)) {}

  const std::string& jobId() const { return jobId_; }
  const std::string& role() const { return role_; }

  // The job as the pump read it (nullopt: gone). Writes it unless a write is under way or
  // nothing changed within the last second.
  void offer(const std::optional<JobInfo>& info, Clock::time_point now) {
    {
      std::lock_guard lock(ops_);
      if (finished_ || writing_) return;
      if (info) {
        if (wrote_ && info->version == lastVersion_ && now - lastWrite_ < kLiveEvery) return;
        status_ = toProto(*info);
        lastVersion_ = info->version;
        lastWrite_ = now;
        wrote_ = true;
        terminal_ = isTerminal(info->state);
        writing_ = true;
        StartWrite(&status_);
        return;
      }
    }
    finish(grpc::Status(grpc::StatusCode::NOT_FOUND, "WatchJob: job " + jobId_ + " was deleted"));
  }

  void OnWriteDone(bool ok) override {
    bool end = false;
    {
      std::lock_guard lock(ops_);
      writing_ = false;
      end = !ok || terminal_;
    }
    if (end) finish(ok ? grpc::Status::OK : grpc::Status(grpc::StatusCode::CANCELLED, "WatchJob: stream ended"));
  }
  void OnCancel() override { finish(grpc::Status(grpc::StatusCode::CANCELLED, "WatchJob: stream ended")); }
  void OnDone() override {
    hub_.remove(this);
    delete this;
  }

  void finish(const grpc::Status& status) {
    {
      std::lock_guard lock(ops_);
      if (finished_) return;
      finished_ = true;
    }
    Finish(status);
  }

 private:
  JobWatchers& hub_;
  const std::string jobId_, role_;
  std::mutex ops_;
  v1::JobStatus status_;
  uint64_t lastVersion_ = 0;
  Clock::time_point lastWrite_;
  bool wrote_ = false, writing_ = false, terminal_ = false, finished_ = false;
};

JobWatchers::JobWatchers(Coordinator& coordinator, size_t maxStreamsPerRole)
    : coordinator_(coordinator), maxPerRole_(maxStreamsPerRole), thread_([this] { run(); }) {}

JobWatchers::~JobWatchers() { stop(); }

grpc::ServerWriteReactor<v1::JobStatus>* JobWatchers::watch(const std::string& jobId, const std::string& role,
                                                            const grpc::Status& refused) {
  auto* stream = new Stream(*this, jobId, role);
  grpc::Status status = refused;
  std::optional<JobInfo> info;
  if (status.ok()) {
    std::lock_guard lock(mutex_);
    if (stopping_) {
      status = grpc::Status(grpc::StatusCode::UNAVAILABLE, "WatchJob: coordinator shutting down");
    } else if (perRole_[role] >= maxPerRole_) {
      status = grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                            "WatchJob: the " + role + " token already has " + std::to_string(maxPerRole_) +
                                " streams open, the most one role may have; close some");
    } else {
      try {
        info = coordinator_.job(jobId);
        streams_.insert(stream);
        ++perRole_[role];
      } catch (const FarmError& e) {
        status = grpc::Status(grpc::StatusCode::NOT_FOUND, std::string("WatchJob: ") + e.what());
      }
    }
  }
  if (!status.ok())
    stream->finish(status);
  else
    stream->offer(info, Clock::now());  // the first status at once
  return stream;
}

void JobWatchers::remove(Stream* stream) {
  std::lock_guard lock(mutex_);
  if (streams_.erase(stream)) --perRole_[stream->role()];
}

size_t JobWatchers::open() const {
  std::lock_guard lock(mutex_);
  return streams_.size();
}

void JobWatchers::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    const std::set<Stream*> open = streams_;  // a stream leaves streams_ only under the lock
    for (Stream* stream : open)
      stream->finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, "WatchJob: coordinator shutting down"));
  }
  stopThread_ = true;
  if (thread_.joinable()) thread_.join();
}

void JobWatchers::run() {
  while (!stopThread_) {
    std::this_thread::sleep_for(kPace);  // the pace of updates, not a wait for a condition
    std::lock_guard lock(mutex_);
    std::map<std::string, std::optional<JobInfo>> jobs;  // each watched job read once per round
    const auto now = Clock::now();
    const std::set<Stream*> open = streams_;  // a stream finished here may remove itself
    for (Stream* stream : open) {
      auto it = jobs.find(stream->jobId());
      if (it == jobs.end()) {
        std::optional<JobInfo> info;
        try {
          info = coordinator_.job(stream->jobId());
        } catch (const FarmError&) {  // deleted
        }
        it = jobs.emplace(stream->jobId(), std::move(info)).first;
      }
      stream->offer(it->second, now);
    }
  }
}

}  // namespace lensfarm
