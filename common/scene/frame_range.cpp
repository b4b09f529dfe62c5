#include "common/scene/frame_range.h"

#include <charconv>
#include <cstdlib>

#include "common/util/error.h"

namespace lensfarm {

namespace {

[[noreturn]] void refuse(const std::string& what, const std::string& text, const std::string& why) {
  throw InputError(text.empty() ? what : what + " " + text, why);
}

const char* const kForms = "give a frame (7), a range (1-240) or a range with a step (1-240x2 or 1-240:2)";

// Reads an integer from [begin, end) with std::from_chars (an optional '-', then digits; no '+'
// or spaces); returns where it stopped.
const char* readInteger(const char* begin, const char* end, int64_t& out, const std::string& what,
                        const std::string& text) {
  const auto [ptr, ec] = std::from_chars(begin, end, out);
  if (ec == std::errc::result_out_of_range || (ec == std::errc() && (out > kMaxFrameNumber || out < -kMaxFrameNumber)))
    refuse(what, text, "frame numbers and steps must be within ±" + std::to_string(kMaxFrameNumber));
  if (ec != std::errc()) refuse(what, text, "is not a frame range: " + std::string(kForms));
  return ptr;
}

// Where the file name starts in a path.
size_t fileNameStart(const std::string& pattern) {
  const size_t slash = pattern.find_last_of('/');
  return slash == std::string::npos ? 0 : slash + 1;
}

}  // namespace

FrameRange parseFrameRange(const std::string& text, const std::string& what) {
  if (text.empty()) refuse(what, text, "is empty: " + std::string(kForms));
  FrameRange range;
  const char* const begin = text.data();
  const char* const end = begin + text.size();
  const size_t stepAt = text.find_first_of("x:");
  const char* const bodyEnd = stepAt == std::string::npos ? end : begin + stepAt;
  const char* p = readInteger(begin, bodyEnd, range.first, what, text);
  range.last = range.first;
  if (p != bodyEnd) {
    if (*p != '-') refuse(what, text, "is not a frame range: " + std::string(kForms));
    p = readInteger(p + 1, bodyEnd, range.last, what, text);
    if (p != bodyEnd) refuse(what, text, "is not a frame range: " + std::string(kForms));
  }
  if (stepAt != std::string::npos) {
    p = readInteger(bodyEnd + 1, end, range.step, what, text);
    if (p != end) refuse(what, text, "is not a frame range: " + std::string(kForms));
    if (range.step < 1) refuse(what, text, "the step must be a positive integer, got " + std::to_string(range.step));
  }
  if (range.last < range.first) refuse(what, text, "the last frame is before the first");
  if (range.count() > kMaxFramesInRange)
    refuse(what, text,
           std::to_string(range.count()) + " frames; at most " + std::to_string(kMaxFramesInRange) + " in one range");
  return range;
}

std::string formatFrameRange(const FrameRange& range) {
  if (range.first == range.last) return std::to_string(range.first);
  std::string out = std::to_string(range.first) + "-" + std::to_string(range.last);
  if (range.step != 1) out += "x" + std::to_string(range.step);
  return out;
}

bool hasFramePattern(const std::string& pattern) {
  return pattern.find('#', fileNameStart(pattern)) != std::string::npos;
}

std::string framePath(const std::string& pattern, int64_t frame) {
  const size_t start = fileNameStart(pattern);
  const size_t last = pattern.find_last_of('#');
  if (last == std::string::npos || last < start) return pattern;
  size_t first = last;
  while (first > start && pattern[first - 1] == '#') --first;
  const size_t width = last - first + 1;
  // The magnitude as unsigned: -INT64_MIN does not fit an int64_t.
  const uint64_t magnitude = frame < 0 ? uint64_t(0) - uint64_t(frame) : uint64_t(frame);
  std::string digits = std::to_string(magnitude);
  if (digits.size() < width) digits.insert(0, width - digits.size(), '0');
  return pattern.substr(0, first) + (frame < 0 ? "-" : "") + digits + pattern.substr(last + 1);
}

void checkFramePattern(const std::string& pattern, const std::string& what) {
  if (hasFramePattern(pattern)) return;
  const bool inDirectory = pattern.find('#') != std::string::npos;
  throw InputError(what + " " + pattern,
                   std::string("a frame pattern needs #### for the frame number when rendering several frames") +
                       (inDirectory ? " (in the file name: a # in a directory name does not count)" : ""));
}

}  // namespace lensfarm
