#pragma once
// The worker's real link to an in-process Coordinator (client/in_process_link.h, as `lensfarm
// render` wires it), every call forwarded: a test derives from it to watch or bend one call.
#include "client/in_process_link.h"
#include "coordinator/core/coordinator.h"

namespace lensfarm::test {

class ForwardingLink : public CoordinatorLink {
 public:
  explicit ForwardingLink(Coordinator& c) : inner_(c) {}
  Registration registerWorker(const WorkerInfo& info) override { return inner_.registerWorker(info); }
  std::vector<uint64_t> heartbeat(const std::string& w, const std::vector<uint64_t>& leases) override {
    return inner_.heartbeat(w, leases);
  }
  std::optional<LeaseGrant> lease(const std::string& w, double wait) override { return inner_.lease(w, wait); }
  JobSpec jobSpec(const std::string& job) override { return inner_.jobSpec(job); }
  std::string asset(const std::string& sha) override { return inner_.asset(sha); }
  bool upload(const UnitResult& r) override { return inner_.upload(r); }
  void reportFailure(const std::string& w, uint64_t lease, const std::string& job, const std::string& e) override {
    inner_.reportFailure(w, lease, job, e);
  }

 protected:
  InProcessLink inner_;
};

}  // namespace lensfarm::test
