// The scheduling commands (docs/farm.md "Scheduling"): pause, resume, approve and update a job,
// each printing the job's id and what it is now; and the farm's events (docs/api.md "Events").
// The exit codes are the farm commands'.
#include <cstdio>
#include <ctime>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/farm_client.h"
#include "client/farm_connection.h"
#include "client/progress_display.h"
#include "common/util/log_text.h"

namespace lensfarm::cli {
namespace {

using Action = v1::JobStatus (FarmClient::*)(const std::string&);

Runner addJobAction(CLI::App& app, const char* name, const char* description, Action action) {
  auto* cmd = app.add_subcommand(name, description);
  auto f = std::make_shared<JobArgs>();
  addJobArgs(cmd, *f);
  return [f, action] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      const v1::JobStatus s = (client.*action)(f->job);
      std::printf("%s %s%s%s%s\n", s.job_id().c_str(), stateName(s.state()), s.paused() ? ", paused" : "",
                  s.approved() ? ", approved" : "", s.prefetch() ? ", prefetching" : "");
      return kOk;
    });
  };
}

}  // namespace

Runner addPauseCommand(CLI::App& app) {
  return addJobAction(app, "pause", "Pause a job: no more of its units are leased; those in flight finish and count",
                      &FarmClient::pause);
}

Runner addResumeCommand(CLI::App& app) {
  return addJobAction(app, "resume", "Resume a paused job", &FarmClient::resume);
}

Runner addApproveCommand(CLI::App& app) {
  return addJobAction(app, "approve", "Approve a job (its preview): jobs submitted --after JOB:approved start",
                      &FarmClient::approve);
}

Runner addPrefetchCommand(CLI::App& app) {
  return addJobAction(app, "prefetch",
                      "Have the workers that may render a job fetch its assets now, before its units are leased",
                      &FarmClient::prefetch);
}

Runner addUpdateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("update", "Change a queued or running job's priority, worker cap or share weight");
  struct Args {
    JobArgs job;
    std::optional<int> priority;
    std::optional<uint32_t> maxWorkers;
    std::optional<double> shareWeight;
  };
  auto f = std::make_shared<Args>();
  addJobArgs(cmd, f->job);
  cmd->add_option("--priority", f->priority, "Its new priority (higher runs first)");
  cmd->add_option("--max-workers", f->maxWorkers, "At most this many workers render it at once (at least 1)");
  cmd->add_option("--share-weight", f->shareWeight, "Its weight among its owner's jobs in the fair share");
  return [f] {
    return guardedCall([&] {
      if (!f->priority && !f->maxWorkers && !f->shareWeight) {
        std::fprintf(stderr, "error: update: give --priority, --max-workers or --share-weight\n");
        return kBadInput;
      }
      v1::UpdateJobRequest request;
      request.set_job_id(f->job.job);
      if (f->priority) request.set_priority(*f->priority);
      if (f->maxWorkers) request.set_max_workers(*f->maxWorkers);
      if (f->shareWeight) request.set_share_weight(*f->shareWeight);
      FarmClient client(f->job.c.coordinator, f->job.c.resolved());
      const v1::JobStatus s = client.update(request);
      const auto& p = s.policy();
      std::printf("%s %s, priority %d, max workers %s, share weight %g\n", s.job_id().c_str(), stateName(s.state()),
                  s.priority(), p.max_workers() ? std::to_string(p.max_workers()).c_str() : "any",
                  p.share_weight() > 0 ? p.share_weight() : 1.0);
      return kOk;
    });
  };
}

Runner addEventsCommand(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("events", "Print the farm's events (jobs started, done, failed; audits; workers lost)");
  struct Args {
    Connection c;
    std::string job;
    uint64_t after = 0;
    bool follow = false;
  };
  auto f = std::make_shared<Args>();
  addCoordinatorOption(cmd, f->c);
  cmd->add_option("--job", f->job, "Only this job's events");
  cmd->add_option("--after", f->after, "Only events after this sequence number");
  cmd->add_flag("--follow,-f", f->follow, "Keep printing new events as they happen (until interrupted)");
  return [f] {
    return guardedCall([&] {
      FarmClient client(f->c.coordinator, f->c.resolved());
      v1::ListEventsRequest request;
      request.set_after(f->after);
      request.set_job_id(f->job);
      for (;;) {
        request.set_wait_seconds(f->follow ? 10.0 : 0.0);
        const v1::ListEventsResponse r = client.events(request);
        if (request.after() + 1 < r.oldest() && r.oldest() > 1)
          std::printf("(events %llu to %llu are no longer held)\n", (unsigned long long)(request.after() + 1),
                      (unsigned long long)(r.oldest() - 1));
        for (const v1::FarmEvent& e : r.events()) {
          const std::time_t t = std::time_t(e.unix_seconds());
          char when[32];
          std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::localtime(&t));
          const std::string subject = !e.job_id().empty() ? e.job_id() : e.worker_id();
          std::printf("%llu %s %-20s %s %s\n", (unsigned long long)e.sequence(), when, e.type().c_str(),
                      subject.c_str(), logText(e.text()).c_str());
        }
        std::fflush(stdout);
        // (filtered by job, the events of others still move the cursor: `latest` is where we are)
        request.set_after(std::max(request.after(), r.events().empty() ? r.latest() : r.events().rbegin()->sequence()));
        if (!f->follow && r.events().empty()) return kOk;
        if (!f->follow && r.events().size() < 1000) return kOk;
      }
    });
  };
}

}  // namespace lensfarm::cli
