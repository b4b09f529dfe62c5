#pragma once
// Progress of a job for people: a bar redrawn in place on a terminal, plain lines otherwise
// (the first at once, then at most one every few seconds, and the last, for logs and pipes).
// The internal sample cap of a job without one (kMaxSamplesPerPixel) is never shown: such a job
// shows its progress toward its target error or deadline instead.
#include <string>

#include "lensfarm/v1/common.pb.h"

namespace lensfarm::cli {

class ProgressDisplay {
 public:
  // `enabled` false: show nothing. `toTerminal`: redraw one line on stderr; otherwise plain
  // lines at most every `plainEverySeconds`. `watchTarget`: a relative error to project the time
  // to, for jobs that have no target of their own.
  ProgressDisplay(bool enabled, bool toTerminal, double watchTarget = 0.0, double plainEverySeconds = 2.0);
  void update(const v1::JobStatus& status);
  void finish();

 private:
  bool enabled_, terminal_;
  double watchTarget_, plainEvery_;
  double lastDraw_ = -1e9;
  size_t lastWidth_ = 0;  // of the line on the terminal, to blank what a shorter one leaves
  bool drawn_ = false;
};

std::string formatDuration(double seconds);
// "err 2.31 % (target 1.00 % in ~0:42)": the live estimate (film/convergence.h) and the projected
// time to the job's target, or to `watchTarget` if the job has none; "err unknown (target 1.00 %)"
// while there is no estimate (fewer than two units, or an image black so far).
std::string convergenceText(const v1::JobProgress& progress, double watchTarget = 0.0);
const char* stateName(v1::JobState state);

// Whether the job has a sample cap of its own (not the internal one of a job that runs until its
// target error or deadline).
bool hasSampleCap(const v1::JobProgress& progress);
// Samples per pixel done, "106/128" with a cap of the job's own, "688" without.
std::string samplesText(const v1::JobProgress& progress);
// The time left, "0:42", or "estimating" while nothing tells it yet (no unit done, or no cap and
// neither an error estimate toward a target nor a deadline).
// "stalled" while no worker renders it (JobProgress.stalled_reason says why).
std::string timeLeftText(const v1::JobStatus& status);
// The line the bar and the plain lines show, e.g.
// "running 688 spp  err 2.31 % (target 1.00 % in ~0:42)  6.01 Mrays/s  1 busy  0:10 elapsed  0:42 left";
// before the first unit "estimating" stands for the rate and the time left. `nowUnixSeconds`
// places a running job within its deadline ("deadline 0:12 of 1:00").
std::string progressLine(const v1::JobStatus& status, double watchTarget, double nowUnixSeconds);

}  // namespace lensfarm::cli
