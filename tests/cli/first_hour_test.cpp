// What a new user meets first, through the real `lensfarm` binary: usage instead of a
// bare error, a suggestion for a typo, flag limits in words, default output names, progress lines
// in logs, no internal sample cap on screen, and a Ctrl-C before the first unit that overwrites
// nothing.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;
using test::lines;
using json = nlohmann::json;

using test::kBadInput;
using test::kInterrupted;
const std::string kInternalCap = "1099511627776";  // kMaxSamplesPerPixel, 2^40

std::string cli() { return test::cliPath().string(); }

test::ProcessResult lensfarm(std::vector<std::string> args, double timeoutSeconds = 60.0) {
  args.insert(args.begin(), cli());
  return test::runProcess(args, timeoutSeconds);
}

// The progress lines of a render's stderr ("job-1: running 48 spp  ...").
std::vector<std::string> progressLines(const std::string& err) {
  std::vector<std::string> out;
  for (const auto& l : lines(err))
    if (std::regex_search(l, std::regex("^job-[0-9]+: (queued|running|done|cancelled|failed) "))) out.push_back(l);
  return out;
}

// ---- entry: usage, help, version, typos -----------------------------------------------------

TEST(CliEntry, NoCommandHelpAndVersionPrintUsageOrVersion) {
  const auto bare = lensfarm({});
  EXPECT_EQ(bare.exitCode, kBadInput) << "no command is a mistake in a script";
  EXPECT_TRUE(contains(bare.err, "Usage: lensfarm"));
  for (const char* command : {"render", "submit", "watch", "status", "help"}) EXPECT_TRUE(contains(bare.err, command));
  EXPECT_EQ(bare.err.find("A subcommand is required"), std::string::npos) << bare.err;

  for (const std::vector<std::string>& args : {std::vector<std::string>{"help"}, {"-h"}, {"--help"}}) {
    SCOPED_TRACE(args[0]);
    const auto r = lensfarm(args);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(contains(r.out, "Usage: lensfarm [OPTIONS]"));
    for (const char* command : {"render", "submit", "watch", "status", "download", "compare"})
      EXPECT_TRUE(contains(r.out, command));
  }

  for (const char* flag : {"-v", "--version"}) {
    SCOPED_TRACE(flag);
    const auto r = lensfarm({flag});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::regex_match(r.out, std::regex("lensfarm-renderer/[0-9.]+\n"))) << r.out;
  }
}

TEST(CliEntry, HelpOfACommandIsItsFlags) {
  const auto r = lensfarm({"help", "render"});
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "Usage: lensfarm render"));
  for (const char* flag : {"--spp", "--time", "--target-error", "--deadline", "--progress-every", "--output"})
    EXPECT_TRUE(contains(r.out, flag));
}

TEST(CliEntry, ATypoNamesTheNearestCommand) {
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  for (const auto& c :
       std::vector<Case>{{{"rendr", "scene.json", "-o", "x.exr"},
                          "lensfarm: error: unknown command 'rendr'; did you mean 'render'?\n"},
                         {{"stauts"}, "lensfarm: error: unknown command 'stauts'; did you mean 'status'?\n"},
                         {{"help", "sumbit"}, "lensfarm: error: unknown command 'sumbit'; did you mean 'submit'?\n"},
                         {{"xyzzy"}, "lensfarm: error: unknown command 'xyzzy'; run 'lensfarm help' for the list\n"}}) {
    SCOPED_TRACE(c.args[0] + " " + (c.args.size() > 1 ? c.args[1] : ""));
    const auto r = lensfarm(c.args);
    EXPECT_EQ(r.exitCode, kBadInput);
    EXPECT_EQ(r.err, c.message);
    EXPECT_EQ(r.out, "");
  }
}

TEST(CliEntry, HelpSaysUnitsNeverPasses) {
  for (const char* command : {"render", "submit", "watch", "status", "download", "snapshot", "study", "dof"}) {
    SCOPED_TRACE(command);
    const auto r = lensfarm({command, "--help"});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_FALSE(std::regex_search(r.out, std::regex("\\bpass(es)?\\b"))) << r.out;
  }
  EXPECT_TRUE(contains(lensfarm({"render", "--help"}).out, "whole number of units"));
}

// ---- flag limits in words -------------------------------------------------------------------

TEST(CliFlags, NumberLimitsAreOneReadableSentence) {
  test::TempDir dir;
  const fs::path scene = dir.write("minimal.json", test::minimalSceneJson().dump(2));
  struct Case {
    std::vector<std::string> args;
    std::string message;  // after "lensfarm: error: "
  };
  const std::vector<Case> cases = {
      {{"--time", "0"}, "--time: must be more than 0 seconds, got 0"},
      {{"--time", "soon"}, "--time: expected a number of seconds, got \"soon\""},
      {{"--deadline", "0s"}, "--deadline: must be more than 0 seconds, got 0s"},
      {{"--deadline", "soon"}, "--deadline: expected a duration such as 45, 90s, 10m or 2h, got \"soon\""},
      {{"--target-error", "2"}, "--target-error: must be from 1e-06 to 0.999, got 2"},
      {{"--spp", "0"}, "--spp: must be a whole number from 1 to 1099511627776, got 0"},
      {{"--spp", "many"}, "--spp: expected a whole number from 1 to 1099511627776, got \"many\""},
      {{"--snapshot-every", "-1"}, "--snapshot-every: must be 0 seconds or more, got -1"},
      {{"--progress-every", "0"}, "--progress-every: must be more than 0 seconds, got 0"},
      {{"--threads", "0"}, "--threads: must be a whole number from 1 to 4096, got 0"},
      {{"--seed", "-1"}, "--seed: must be a whole number from 0 to 18446744073709551615, got -1"},
      {{"--ev", "100"}, "--ev: must be from -64 to 64 stops, got 100"},
      {{"--ev", "nan"}, "--ev: expected a number from -64 to 64 stops, got \"nan\""},
      {{"--ev", "inf"}, "--ev: expected a number from -64 to 64 stops, got \"inf\""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args[0] + " " + c.args[1]);
    std::vector<std::string> args = {"render", scene.string(), "-q", "-o", (dir / "x.exr").string()};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = lensfarm(args, 30);
    EXPECT_EQ(r.exitCode, kBadInput);
    EXPECT_EQ(r.err, "lensfarm: error: " + c.message + "\n");
    EXPECT_FALSE(fs::exists(dir / "x.exr"));
  }
  const auto dof = lensfarm({"dof", scene.string(), "--f-numbers", "2,0"}, 30);
  EXPECT_EQ(dof.exitCode, kBadInput);
  EXPECT_EQ(dof.err, "lensfarm: error: --f-numbers: must be more than 0, got 0\n");
}

// `download` and `snapshot` take an EV of their own: the same finite range, checked before any
// coordinator is asked (none runs here).
TEST(CliFlags, ExposureOfADownloadOrSnapshotIsAFiniteNumberOfStops) {
  test::TempDir dir;
  for (const char* command : {"download", "snapshot"})
    for (const char* ev : {"nan", "inf", "-100"}) {
      SCOPED_TRACE(std::string(command) + " --ev " + ev);
      const auto r =
          lensfarm({command, "job-1", "-o", (dir / "x.png").string(), "--ev", ev, "--coordinator", "127.0.0.1:1"}, 30);
      EXPECT_EQ(r.exitCode, kBadInput);
      EXPECT_TRUE(r.err.rfind("lensfarm: error: --ev: ", 0) == 0) << r.err;
      EXPECT_TRUE(contains(r.err, "from -64 to 64 stops")) << r.err;
      EXPECT_FALSE(fs::exists(dir / "x.png"));
    }
}

// ---- default outputs ------------------------------------------------------------------------

TEST(CliOutputs, WithoutOutputFlagsRenderWritesSceneNamedFilesInTheCurrentDirectory) {
  test::TempDir scenes, work;
  const fs::path scene = scenes.write("tiny-box.json", test::minimalSceneJson().dump(2));
  // env -C: the render runs in `work`, where the images must appear.
  const auto r = test::runProcess(
      {"/usr/bin/env", "-C", work.path().string(), cli(), "render", scene.string(), "--spp", "2", "-q"}, 60);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(work / "tiny-box.exr"));
  EXPECT_TRUE(fs::is_regular_file(work / "tiny-box.png"));
  EXPECT_TRUE(contains(r.out, "wrote tiny-box.exr\n"));
  EXPECT_TRUE(contains(r.out, "wrote tiny-box.png\n"));
  EXPECT_FALSE(fs::exists(scenes / "tiny-box.exr")) << "beside the scene is not the current directory";
}

// ---- progress for logs ----------------------------------------------------------------------

// The minimal scene at `side` x `side` pixels in units of `perUnit` spp.
fs::path sceneWithUnits(const test::TempDir& dir, int side, uint64_t spp, uint32_t perUnit) {
  json j = test::minimalSceneJson();
  j["render"]["resolution"] = {side, side};
  j["render"]["samples_per_pixel"] = spp;
  j["render"]["samples_per_unit"] = perUnit;
  return dir.write("units.json", j.dump(2));
}

TEST(CliProgress, PlainLinesWhenStderrIsNotATerminalEstimatingUntilTheFirstUnit) {
  test::TempDir dir;
  // Three units of 2^21 paths: the first takes a good fraction of a second, so the first line
  // (drawn at once) comes before any unit is in.
  const fs::path scene = sceneWithUnits(dir, 64, 3 * 512, 512);
  const auto r = lensfarm({"render", scene.string(), "--progress-every", "0.1", "-o", (dir / "x.exr").string()}, 120);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto progress = progressLines(r.err);
  ASSERT_GE(progress.size(), 2u) << r.err;
  EXPECT_TRUE(contains(progress.front(), "running 0/1536 spp")) << "the first line at once: " << r.err;
  for (const auto& line : progress) {
    SCOPED_TRACE(line);
    if (line.find(" 0/1536 spp") == std::string::npos) continue;  // only lines from before the first unit
    EXPECT_TRUE(contains(line, "estimating"));
    EXPECT_EQ(line.find("Mrays/s"), std::string::npos) << "no rate before there is one";
    EXPECT_EQ(line.find("0:00 left"), std::string::npos) << "no time left before there is one";
  }
  EXPECT_TRUE(std::regex_search(progress.back(), std::regex("done 1536/1536 spp .* Mrays/s"))) << progress.back();

  const auto quiet =
      lensfarm({"render", scene.string(), "-q", "--progress-every", "0.1", "-o", (dir / "x.exr").string()}, 120);
  ASSERT_EQ(quiet.exitCode, 0) << quiet.err;
  EXPECT_TRUE(progressLines(quiet.err).empty()) << quiet.err;
}

TEST(CliProgress, ATargetOrDeadlineWithoutSppShowsItsRuleNeverTheInternalCap) {
  test::TempDir dir;
  json j = test::minimalSceneJson();
  j["render"]["resolution"] = {32, 32};
  const fs::path scene = dir.write("small.json", j.dump(2));
  struct Case {
    std::vector<std::string> args;
    std::string rule;  // what the progress lines show instead of a total
  };
  for (const auto& c : std::vector<Case>{{{"--target-error", "0.03"}, "(target 3.00 %"},
                                         {{"--time", "1"}, "deadline 0:0"},
                                         {{"--deadline", "1s"}, "deadline 0:0"}}) {
    SCOPED_TRACE(c.args[0]);
    std::vector<std::string> args = {"render", scene.string(), "--progress-every",
                                     "0.1",    "-o",           (dir / "x.exr").string()};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const auto r = lensfarm(args, 120);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ((r.out + r.err).find(kInternalCap), std::string::npos) << r.out << r.err;
    const auto progress = progressLines(r.err);
    ASSERT_FALSE(progress.empty()) << r.err;
    for (const auto& line : progress) {
      EXPECT_TRUE(contains(line, c.rule));
      EXPECT_TRUE(std::regex_search(line, std::regex(" [0-9]+ spp "))) << "spp done without a total: " << line;
    }
  }
}

// A job without --spp on a farm: `status` shows what was done, never the internal cap. No worker
// is needed: the job stays queued.
TEST(CliProgress, StatusOfAJobWithoutSppNeverShowsTheInternalCap) {
  test::TempDir dir;
  const fs::path scene = dir.write("small.json", test::minimalSceneJson().dump(2));
  const fs::path portFile = dir / "port";
  test::ChildProcess coordinator(
      {test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--port-file", portFile.string()},
      dir / "coordinator");
  ASSERT_TRUE(test::waitFor([&] { return !test::readFile(portFile).empty() || !coordinator.running(); }, 30))
      << coordinator.log();
  std::string address = test::readFile(portFile);
  address.erase(address.find_last_not_of('\n') + 1);
  ASSERT_FALSE(address.empty()) << coordinator.log();

  for (const std::vector<std::string>& rule :
       {std::vector<std::string>{"--target-error", "0.01"}, {"--deadline", "10m"}}) {
    SCOPED_TRACE(rule[0]);
    std::vector<std::string> args = {"submit", scene.string(), "--coordinator", address};
    args.insert(args.end(), rule.begin(), rule.end());
    const auto submitted = lensfarm(args);
    ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
    const std::string job = submitted.out.substr(0, submitted.out.find('\n'));
    const auto status = lensfarm({"status", job, "--coordinator", address});
    ASSERT_EQ(status.exitCode, 0) << status.err;
    EXPECT_EQ(status.out.find(kInternalCap), std::string::npos) << status.out;
    EXPECT_TRUE(contains(status.out, "samples:    0 per pixel (0 units; no sample cap)"));
    EXPECT_TRUE(contains(status.out, "remaining:  "));
    EXPECT_EQ(status.out.find("remaining:  0:00"), std::string::npos) << "a queued job has time left" << status.out;
  }
  const auto list = lensfarm({"status", "--coordinator", address});
  ASSERT_EQ(list.exitCode, 0) << list.err;
  EXPECT_EQ(list.out.find(kInternalCap), std::string::npos) << list.out;
}

// ---- Ctrl-C before the first unit ----------------------------------------------------------

// A render that leaves out what the scene asks for says so before the first ray (not only in the
// summary at the end): the 2013 report's f/16 lens at a preview size is traced as a pinhole.
TEST(CliEffects, DepthOfFieldLeftOutAtAPreviewSizeIsAWarningBeforeTheRender) {
  test::TempDir dir;
  const std::string scene = (test::scenesDir() / "cornell-seed.json").string();
  const auto preview =
      lensfarm({"render", scene, "--resolution", "64x64", "--spp", "1", "-q", "-o", (dir / "p.exr").string()});
  ASSERT_EQ(preview.exitCode, 0) << preview.err;
  const size_t warning = preview.err.find("depth of field is not simulated");
  ASSERT_NE(warning, std::string::npos) << preview.err;
  EXPECT_TRUE(contains(preview.err.substr(warning), "traced as a pinhole at 64x64 px"));
  EXPECT_TRUE(contains(preview.err, "warning")) << "a warning, not an info line";
  // At its own size the scene simulates its lens, and nothing is said.
  const auto full = lensfarm({"render", scene, "--spp", "1", "--time", "0.001", "-q", "-o", (dir / "f.exr").string()});
  ASSERT_EQ(full.exitCode, 0) << full.err;
  EXPECT_EQ(full.err.find("is not simulated"), std::string::npos) << full.err;
}

TEST(CliInterrupt, CtrlCBeforeTheFirstUnitOverwritesNothingAndSaysSo) {
  // Units of 2^26 paths: many seconds, so Ctrl-C always comes before the first is done; rows
  // (where the worker checks for a cancel) of 2^17 paths, so it stops at once.
  for (const bool snapshots : {false, true}) {
    SCOPED_TRACE(snapshots ? "with --snapshot-every" : "without snapshots");
    test::TempDir dir;
    const fs::path scene = sceneWithUnits(dir, 512, 4 * 256, 256);
    const fs::path exr = dir.write("kept.exr", "the user's own EXR bytes");
    const fs::path png = dir.write("kept.png", "the user's own PNG bytes");
    std::vector<std::string> argv = {cli(), "render", scene.string(), "-o", exr.string(), "-o", png.string()};
    if (snapshots) argv.insert(argv.end(), {"--snapshot-every", "0.01"});
    test::ChildProcess render(argv, dir / "render");
    // The log line that starts the render comes once Ctrl-C is handled.
    ASSERT_TRUE(
        test::waitFor([&] { return render.log().find("triangles") != std::string::npos || !render.running(); }, 60))
        << render.log();
    render.signal(SIGINT);
    const int code = render.wait(60);
    EXPECT_EQ(code, kInterrupted) << render.log();
    EXPECT_TRUE(test::readFile(exr) == "the user's own EXR bytes") << "kept.exr was overwritten";
    EXPECT_TRUE(test::readFile(png) == "the user's own PNG bytes") << "kept.png was overwritten";
    EXPECT_TRUE(contains(render.log(), "nothing was rendered (no samples)"));
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"kept.exr", "kept.png", "render.stderr", "render.stdout", "units.json"}))
        << "no temporary or other file left";
  }
}

}  // namespace
}  // namespace lensfarm
