// The scheduling commands (docs/farm.md "Scheduling"): pause, resume and approve a job. Each
// prints the job's id and what it is now; the exit codes are the farm commands'.
#include <cstdio>

#include "client/commands.h"
#include "client/exit_codes.h"
#include "client/farm_client.h"
#include "client/farm_connection.h"
#include "client/progress_display.h"

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
      std::printf("%s %s%s%s\n", s.job_id().c_str(), stateName(s.state()), s.paused() ? ", paused" : "",
                  s.approved() ? ", approved" : "");
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

}  // namespace lensfarm::cli
