#pragma once
// Frame ranges and output file patterns of an animation job (docs/scene-format.md, "Frame ranges
// and output patterns").
//
// A frame range is written as one frame "7", a range "1-240" (both ends included), or a range
// with a step "1-240x2" (Nuke's and Deadline's form) or "1-240:2": the frames first,
// first + step, ... up to last. Frame numbers are integers in [-kMaxFrameNumber,
// kMaxFrameNumber]; a negative one carries its minus sign ("-5", "-10-10", "-5--1": the dash
// after a number always separates the two ends, so there is no ambiguity). No spaces, no lists.
//
// An output pattern names each frame's file: the last run of '#' in its file name (never in a
// directory name) becomes the frame number, zero-padded to the run's length, e.g.
// "out/shot_####.exr" -> "out/shot_0007.exr".
#include <cstdint>
#include <string>

namespace lensfarm {

inline constexpr int64_t kMaxFrameNumber = 1'000'000'000;
// A job's status lists every frame (JobStatus.frames): 100,000 keep it far below gRPC's 4 MiB.
inline constexpr uint64_t kMaxFramesInRange = 100'000;

struct FrameRange {
  int64_t first = 1, last = 1, step = 1;  // first <= last, step >= 1

  // How many frames: first, first + step, ... <= last.
  uint64_t count() const { return last < first || step < 1 ? 0 : uint64_t((last - first) / step) + 1; }
  // The i-th frame (i < count()).
  int64_t frameAt(uint64_t i) const { return first + int64_t(i) * step; }
};

// Reads "7", "1-240", "1-240x2" or "1-240:2". Throws InputError naming `what` (a flag such as
// "--frames") and the text, e.g. "--frames 240-1: the last frame is before the first", for empty
// text, anything else than that syntax, frame numbers beyond kMaxFrameNumber, an inverted range,
// a step below 1, and more than kMaxFramesInRange frames.
FrameRange parseFrameRange(const std::string& text, const std::string& what);

// The text parseFrameRange reads back as `range`: "7", "1-240" or "1-240x2".
std::string formatFrameRange(const FrameRange& range);

// Whether the file name of `pattern` (the part after its last '/') has a '#'.
bool hasFramePattern(const std::string& pattern);

// `pattern` with the last run of '#' in its file name replaced by `frame`, zero-padded to the
// run's length (with more digits if the frame needs them; a negative frame's minus sign goes
// before its padded digits: "####" and -5 give "-0005"). A pattern without a '#' in its file
// name is returned unchanged.
std::string framePath(const std::string& pattern, int64_t frame);

// Throws InputError naming `what` and the pattern when it has no '#' in its file name, e.g.
// "-o out/shot.exr: a frame pattern needs #### for the frame number when rendering several frames".
void checkFramePattern(const std::string& pattern, const std::string& what);

}  // namespace lensfarm
