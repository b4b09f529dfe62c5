#pragma once
// Progress of a job for people: a bar redrawn in place on a terminal, plain lines otherwise
// (at most one every few seconds, for logs and pipes).
#include <string>

#include "lensfarm/v1/common.pb.h"

namespace lensfarm::cli {

class ProgressDisplay {
 public:
  // `enabled` false: show nothing. `toTerminal`: redraw one line on stderr. `watchTarget`: a
  // relative error to project the time to, for jobs that have no target of their own.
  ProgressDisplay(bool enabled, bool toTerminal, double watchTarget = 0.0);
  void update(const v1::JobStatus& status);
  void finish();

 private:
  bool enabled_, terminal_;
  double watchTarget_;
  double lastDraw_ = -1e9;
  bool drawn_ = false;
};

std::string formatDuration(double seconds);
// "err 2.31 % (target 1.00 % in ~0:42)": the live estimate (film/convergence.h) and the projected
// time to the job's target, or to `watchTarget` if the job has none.
std::string convergenceText(const v1::JobProgress& progress, double watchTarget = 0.0);
const char* stateName(v1::JobState state);

}  // namespace lensfarm::cli
