#pragma once
// Every open WatchJob stream, served by gRPC's callback API and one thread of its own, so that N
// watchers cost N small objects, never N threads (the sync API pinned a thread to each stream, and
// 2,000 viewer streams made 2,000 threads). Ten times a second the thread reads each watched job
// once and writes its status to each of the job's streams whose last write is done, if the job
// changed since that stream's last status or a second has passed (elapsed time and rates stay
// live); a stream ends OK after the status of a finished job, NOT_FOUND when the job is deleted.
//
// Streams are capped per caller role (client, viewer, or anyone when there is no token): past
// the cap a new stream is refused RESOURCE_EXHAUSTED, naming the role and the cap.
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "coordinator/core/coordinator.h"
#include "lensfarm/v1/client_service.grpc.pb.h"

namespace lensfarm {

class JobWatchers {
 public:
  JobWatchers(Coordinator& coordinator, size_t maxStreamsPerRole);
  ~JobWatchers();  // stop()
  JobWatchers(const JobWatchers&) = delete;
  JobWatchers& operator=(const JobWatchers&) = delete;

  // A reactor for a new stream watching `jobId` for a caller of `role`; one that finishes at once
  // with `refused` if that is not OK, or with RESOURCE_EXHAUSTED past the role's cap.
  grpc::ServerWriteReactor<v1::JobStatus>* watch(const std::string& jobId, const std::string& role,
                                                 const grpc::Status& refused);

  // Ends every stream (UNAVAILABLE, "coordinator shutting down") and refuses new ones: call before
  // grpc::Server::Shutdown, which would otherwise wait out its deadline for open streams.
  void stop();

  size_t open() const;  // streams open now

 private:
  class Stream;
  void run();
  void remove(Stream* stream);

  Coordinator& coordinator_;
  const size_t maxPerRole_;
  // Recursive: a stream finished by the pump or by stop() may end (and remove itself) on the same
  // thread.
  mutable std::recursive_mutex mutex_;
  std::set<Stream*> streams_;
  std::map<std::string, size_t> perRole_;
  bool stopping_ = false;
  std::atomic<bool> stopThread_{false};
  std::thread thread_;
};

}  // namespace lensfarm
