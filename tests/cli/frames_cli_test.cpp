// Frames and tiles on the command line (docs/cli.md, docs/farm.md "Tiles and passes"): each bad
// --frames, -o pattern or --tile-size is one clear error naming the flag, exit 2, nothing written
// — for `render` and, before any connection, for `submit`; and a frame pattern's #s are the
// frame number padded to their count.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;
using test::kBadInput;

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

test::ProcessResult cli(std::vector<std::string> args) {
  args.insert(args.begin(), test::cliPath().string());
  return test::runProcess(args, 120);
}

struct BadFlags {
  std::vector<std::string> flags;
  std::string message;  // in the one line on stderr
};

TEST(FramesCli, EachBadFrameRangePatternOrTileSizeIsOneClearErrorAndWritesNothing) {
  test::TempDir dir;
  const fs::path scene = dir.write("scene.json", test::minimalSceneJson().dump(2));  // 16x16
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const std::string pattern = (out / "shot_####.exr").string();
  const std::vector<BadFlags> cases = {
      {{"--frames", "", "-o", pattern}, "error: --frames: is empty: give a frame (7), a range (1-240)"},
      {{"--frames", "10-1", "-o", pattern}, "error: --frames 10-1: the last frame is before the first"},
      {{"--frames", "1-10x0", "-o", pattern}, "error: --frames 1-10x0: the step must be a positive integer, got 0"},
      {{"--frames", "1-3", "-o", (out / "shot.exr").string()},
       "shot.exr: a frame pattern needs #### for the frame number when rendering several frames"},
      {{"--tile-size", "0", "-o", (out / "still.exr").string()},
       "error: --tile-size: expected auto, off or a tile edge in pixels in [1, 16384], got \"0\""},
      {{"--tile-size", "99999", "-o", (out / "still.exr").string()},
       "error: --tile-size: expected auto, off or a tile edge in pixels in [1, 16384], got \"99999\""},
      {{"--tile-size", "17", "-o", (out / "still.exr").string()}, "tile_size: 17 is larger than the 16x16 frame"},
  };
  for (const BadFlags& c : cases) {
    for (const std::string command : {"render", "submit"}) {
      std::vector<std::string> args = {command, scene.string()};
      for (const std::string& f : c.flags) args.push_back(f);
      if (command == "submit") {
        // `submit` takes no -o: drop it, and name a coordinator nobody serves — the flag is refused
        // before any connection (exit 2, not 3 "unavailable").
        const auto o = std::find(args.begin(), args.end(), "-o");
        if (c.message.find("frame pattern") != std::string::npos) continue;  // a pattern is `download`'s
        args.erase(o, o + 2);
        args.insert(args.end(), {"--coordinator", "127.0.0.1:1"});
      }
      SCOPED_TRACE(command + " " + c.message);
      const auto r = cli(args);
      EXPECT_FALSE(r.timedOut);
      EXPECT_EQ(r.exitCode, kBadInput) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
      EXPECT_TRUE(contains(r.err, c.message));
      EXPECT_TRUE(r.out.empty()) << r.out;
      EXPECT_TRUE(entries(out).empty()) << "written: " << entries(out).front();
    }
  }
}

TEST(FramesCli, APatternWithTwoHashesNamesEachFrameWithTwoDigits) {
  test::TempDir dir;
  const fs::path scene = dir.write("scene.json", test::bundledSceneJson("cornell-animated.json").dump(2));
  const fs::path out = dir / "out";
  fs::create_directories(out);
  const auto r = cli({"render", scene.string(), "--frames", "1-3", "-o", (out / "a_##.png").string(), "--resolution",
                      "16x16", "--spp", "1", "--threads", "2", "-q"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(entries(out), (std::vector<std::string>{"a_01.png", "a_02.png", "a_03.png"}));
  // Each file is its own frame: the camera and a block move between frames 1 and 3.
  EXPECT_NE(test::readFile(out / "a_01.png"), test::readFile(out / "a_03.png"));
}

}  // namespace
}  // namespace lensfarm
