#pragma once
// Progress of a job for people: a bar redrawn in place on a terminal, plain lines otherwise
// (at most one every few seconds, for logs and pipes).
#include <string>

#include "lensfarm/v1/common.pb.h"

namespace lensfarm::cli {

class ProgressDisplay {
 public:
  // `enabled` false: show nothing. `toTerminal`: redraw one line on stderr.
  ProgressDisplay(bool enabled, bool toTerminal, double timeLimitSeconds = 0.0);
  void update(const v1::JobStatus& status);
  void finish();

 private:
  bool enabled_, terminal_;
  double timeLimit_;
  double lastDraw_ = -1e9;
  bool drawn_ = false;
};

std::string formatDuration(double seconds);
const char* stateName(v1::JobState state);

}  // namespace lensfarm::cli
