#pragma once
// Weighted fair share of the farm's samples between owners, and between the jobs of one owner
// (docs/farm.md "Scheduling"), by start-time fair queuing (Goyal, Vin & Cheng, "Start-time Fair
// Queuing", SIGCOMM 1996; as stride scheduling, Waldspurger & Weihl 1995): each owner has a
// virtual time, which a lease of c pixel-samples advances by c / weight; the next lease goes to
// the owner with the least virtual time among those with work. An owner that had no work (or
// is new) starts from the virtual time of the last lease, so idle time is not banked: two
// owners with work take turns in proportion to their weights, however long one was away.
//
// Within the owner the same rule chooses among its jobs (a job's weight: JobPolicy::shareWeight).
// Priorities stay strict: a job is compared by this only with jobs of its own priority
// (Coordinator's tryLease). The virtual times are this process's: a restart begins them anew.
// Not thread-safe (Coordinator::mutex_).
#include <map>
#include <string>

namespace lensfarm {

class FairShare {
 public:
  // The virtual time `owner` would be served at now: its own, or the last lease's if later.
  double ownerStart(const std::string& owner) const;
  // The same for `job` among its owner's jobs.
  double jobStart(const std::string& owner, const std::string& job) const;
  // A lease of `cost` pixel-samples of `job` (of `owner`) was granted: both virtual times advance.
  void charge(const std::string& owner, double ownerWeight, const std::string& job, double jobWeight, double cost);
  // The job ended or was deleted: its virtual time is dropped (the owner's stays).
  void forgetJob(const std::string& owner, const std::string& job);

 private:
  struct Owner {
    double finish = 0.0;                 // its virtual time after its last lease
    double lastStart = 0.0;              // of its jobs: the virtual time of its last lease
    std::map<std::string, double> jobs;  // each job's virtual time after its last lease
  };
  double lastStart_ = 0.0;  // the virtual time of the last lease of any owner
  std::map<std::string, Owner> owners_;
};

}  // namespace lensfarm
