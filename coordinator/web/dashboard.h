#pragma once
// The web dashboard's answers, with no network code: the job and worker lists and a job's detail
// as JSON, snapshot PNGs at an exposure and size, the EXR and PNG downloads, and the actions
// (cancel, priority). dashboard_server.h serves them over HTTP; docs/dashboard.md lists the
// endpoints and the JSON fields.
#include <optional>
#include <string>
#include <vector>

#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/users.h"

namespace lensfarm {

// The JSON texts of one job's detail (its summary, effects, error history, audit counts and
// events) and of the worker list, from what the coordinator reports; Dashboard serves them.
std::string jobDetailJson(const JobInfo& info, const std::vector<ErrorPoint>& errorHistory);
std::string workerListJson(const std::vector<WorkerView>& workers);

class Dashboard {
 public:
  // `clientToken`: the token every /api request must carry ("Bearer <token>"), for everything;
  // none: open (a loopback-only coordinator). `viewerToken` (only with a client token): read-only.
  // `users` (--users, users.h): each person's own token reads here; their actions go through the
  // HTTP API (/api/v1, rest_api.h), which checks their role on the job.
  Dashboard(Coordinator& coordinator, std::optional<std::string> clientToken,
            std::optional<std::string> viewerToken = std::nullopt, std::vector<User> users = {})
      : coordinator_(coordinator),
        token_(std::move(clientToken)),
        viewerToken_(std::move(viewerToken)),
        users_(std::move(users)) {}

  // What an Authorization header value admits: nothing, reading (the viewer token: the lists,
  // details, images and downloads) or everything (the client token, or no token required).
  // Both tokens are compared whole, in constant time.
  enum class Access { kNone, kRead, kFull };
  Access access(const std::string& authorizationHeader) const;
  // The person whose token the header carries (users.h), or nullopt.
  std::optional<User> userOf(const std::string& authorizationHeader) const;
  bool authorized(const std::string& authorizationHeader) const { return access(authorizationHeader) != Access::kNone; }
  bool tokenRequired() const { return token_.has_value(); }
  bool viewerToken() const { return token_.has_value() && viewerToken_.has_value(); }

  // JSON texts. FarmError kNotFound for an unknown job.
  std::string jobsJson() const;                         // {"jobs": [job summary...]} in serving order
  std::string jobJson(const std::string& jobId) const;  // jobDetailJson of the job
  std::string workersJson() const;                      // {"workers": [...]}

  struct Png {
    std::string bytes;
    int width = 0, height = 0;
    uint64_t samplesPerPixel = 0;  // of the image in it
    uint64_t version = 0;          // the job's version when it was made
    double ev = 0.0;               // exposure compensation applied after the automatic exposure
  };
  // The image as it is now, box-filtered to fit `maxSide` (clamped to [16, 1024]) and exposed
  // automatically with `ev` (the scene's own when absent).
  Png snapshot(const std::string& jobId, std::optional<double> ev, int maxSide) const;
  // The downloads: the EXR (linear, with provenance) and the full-size PNG.
  std::string exr(const std::string& jobId) const;
  Png png(const std::string& jobId, std::optional<double> ev) const;

  // Actions; each returns the job's summary JSON afterwards.
  std::string cancel(const std::string& jobId);
  std::string setPriority(const std::string& jobId, int priority);
  std::string pause(const std::string& jobId);  // docs/farm.md "Scheduling"
  std::string resume(const std::string& jobId);
  std::string approve(const std::string& jobId);

 private:
  Coordinator& coordinator_;
  std::optional<std::string> token_, viewerToken_;
  std::vector<User> users_;
};

}  // namespace lensfarm
