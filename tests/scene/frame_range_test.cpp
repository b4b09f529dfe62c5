// Frame ranges ("7", "1-240", "1-240x2", "1-240:2", negative frames) and output patterns
// ("out/shot_####.exr"): every accepted form, every refused one with its message, padding,
// frames wider than the run, negative frames, and '#' in a directory name (which does not count).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/scene/frame_range.h"
#include "common/util/error.h"

namespace lensfarm {
namespace {

std::vector<int64_t> framesOf(const FrameRange& r) {
  std::vector<int64_t> out;
  for (uint64_t i = 0; i < r.count(); ++i) out.push_back(r.frameAt(i));
  return out;
}

std::vector<int64_t> parsed(const std::string& text) { return framesOf(parseFrameRange(text, "--frames")); }

TEST(FrameRange, EveryAcceptedForm) {
  EXPECT_EQ(parsed("7"), (std::vector<int64_t>{7}));
  EXPECT_EQ(parsed("0"), (std::vector<int64_t>{0}));
  EXPECT_EQ(parsed("1-5"), (std::vector<int64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(parsed("3-3"), (std::vector<int64_t>{3}));
  EXPECT_EQ(parsed("1-10x4"), (std::vector<int64_t>{1, 5, 9}));  // the last frame need not be on the step
  EXPECT_EQ(parsed("1-9:4"), (std::vector<int64_t>{1, 5, 9}));
  EXPECT_EQ(parsed("7x3"), (std::vector<int64_t>{7}));
  EXPECT_EQ(parsed("-5"), (std::vector<int64_t>{-5}));
  EXPECT_EQ(parsed("-2-2"), (std::vector<int64_t>{-2, -1, 0, 1, 2}));
  EXPECT_EQ(parsed("-5--3"), (std::vector<int64_t>{-5, -4, -3}));
  EXPECT_EQ(parsed("-6--1x2"), (std::vector<int64_t>{-6, -4, -2}));
  const FrameRange r = parseFrameRange("1-240", "--frames");
  EXPECT_EQ(r.first, 1);
  EXPECT_EQ(r.last, 240);
  EXPECT_EQ(r.step, 1);
  EXPECT_EQ(r.count(), 240u);
  EXPECT_EQ(parseFrameRange("1-240x2", "--frames").count(), 120u);
  EXPECT_EQ(parseFrameRange("1-100000", "--frames").count(), 100000u);  // the most frames in one range
  EXPECT_EQ(parseFrameRange("-1000000000-1000000000x40000", "--frames").count(), 50001u);  // the widest frame numbers
}

TEST(FrameRange, FormatReadsBack) {
  for (const char* text : {"7", "-7", "1-240", "1-240x2", "-5--1", "-10-10x5"}) {
    const FrameRange r = parseFrameRange(text, "--frames");
    EXPECT_EQ(formatFrameRange(r), text);
    const FrameRange again = parseFrameRange(formatFrameRange(r), "--frames");
    EXPECT_EQ(framesOf(again), framesOf(r));
  }
  EXPECT_EQ(formatFrameRange(parseFrameRange("1-9:4", "--frames")), "1-9x4");
}

// The message of the InputError, or "<accepted>".
std::string errorOf(const std::string& text) {
  try {
    (void)parseFrameRange(text, "--frames");
  } catch (const InputError& e) {
    return e.what();
  }
  return "<accepted>";
}

TEST(FrameRange, EveryBadInputIsOneClearError) {
  EXPECT_EQ(errorOf(""),
            "--frames: is empty: give a frame (7), a range (1-240) or a range with a step (1-240x2 or 1-240:2)");
  EXPECT_EQ(errorOf("240-1"), "--frames 240-1: the last frame is before the first");
  EXPECT_EQ(errorOf("-1--5"), "--frames -1--5: the last frame is before the first");
  EXPECT_EQ(errorOf("1-240x0"), "--frames 1-240x0: the step must be a positive integer, got 0");
  EXPECT_EQ(errorOf("1-240x-2"), "--frames 1-240x-2: the step must be a positive integer, got -2");
  EXPECT_EQ(errorOf("1-200000"), "--frames 1-200000: 200000 frames; at most 100000 in one range");
  EXPECT_EQ(errorOf("1-99999999999999999999"),
            "--frames 1-99999999999999999999: frame numbers and steps must be within ±1000000000");
  EXPECT_EQ(errorOf("2000000000"), "--frames 2000000000: frame numbers and steps must be within ±1000000000");
  for (const char* bad : {"a", "1-", "-", "1-b", "1..240", "1-240x", "1-240x2x3", "1-240:2:3", "1 - 240", " 7", "7 ",
                          "+7", "1,2,3", "1-2-3", "--5", "1-240x2.5", "1.5", "x2", "1-240y2"}) {
    SCOPED_TRACE(bad);
    const std::string e = errorOf(bad);
    EXPECT_EQ(e.rfind(std::string("--frames ") + bad + ": ", 0), 0u) << e;
    EXPECT_NE(e.find("is not a frame range"), std::string::npos) << e;
  }
}

TEST(FramePath, PadsToTheRunOfHashes) {
  EXPECT_EQ(framePath("out/shot_####.exr", 7), "out/shot_0007.exr");
  EXPECT_EQ(framePath("out/shot_####.exr", 0), "out/shot_0000.exr");
  EXPECT_EQ(framePath("out/shot_#.exr", 7), "out/shot_7.exr");
  EXPECT_EQ(framePath("shot_####.exr", 1234), "shot_1234.exr");
  // A frame wider than the run takes more digits.
  EXPECT_EQ(framePath("out/shot_##.exr", 12345), "out/shot_12345.exr");
  // Negative frames: the minus sign before the padded digits.
  EXPECT_EQ(framePath("out/shot_####.exr", -5), "out/shot_-0005.exr");
  EXPECT_EQ(framePath("out/shot_#.exr", -12), "out/shot_-12.exr");
  EXPECT_EQ(framePath("s#", INT64_MIN), "s-9223372036854775808");
  // Only the last run counts; '#' in a directory name is left alone.
  EXPECT_EQ(framePath("out/v#_###_##.exr", 3), "out/v#_###_03.exr");
  EXPECT_EQ(framePath("take##/shot_####.exr", 42), "take##/shot_0042.exr");
  EXPECT_EQ(framePath("take##/shot.exr", 42), "take##/shot.exr");  // no run in the file name: unchanged
  EXPECT_EQ(framePath("shot.exr", 42), "shot.exr");
}

TEST(FramePath, APatternNeedsAHashInTheFileName) {
  EXPECT_TRUE(hasFramePattern("out/shot_####.exr"));
  EXPECT_FALSE(hasFramePattern("out/shot.exr"));
  EXPECT_FALSE(hasFramePattern("out##/shot.exr"));
  EXPECT_NO_THROW(checkFramePattern("out/shot_####.exr", "-o"));
  try {
    checkFramePattern("out/shot.exr", "-o");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "-o out/shot.exr: a frame pattern needs #### for the frame number when rendering several frames");
  }
  try {
    checkFramePattern("out##/shot.exr", "-o");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "-o out##/shot.exr: a frame pattern needs #### for the frame number when rendering several frames (in "
                 "the file name: a # in a directory name does not count)");
  }
}

}  // namespace
}  // namespace lensfarm
