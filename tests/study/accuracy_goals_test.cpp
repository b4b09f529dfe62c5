// `lensfarm-accuracy-goals --quick` (bench/accuracy_goals.cpp) end to end, in a second or two: it
// caches its two references, prints a row for each goal, goal 1 reaches its target, the 2013
// report's job renders exactly the paths asked for, and NEE + MIS reaches the naive job's error with fewer
// samples per pixel. Sample counts, not times: the renders are deterministic for given seeds
// (render/unit_renderer.h), the clock on a shared machine is not.
#include <gtest/gtest.h>

#include <sstream>

#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// The cells of the table row whose goal column starts with `prefix`; empty if there is none.
std::vector<std::string> tableRow(const std::string& out, const std::string& prefix) {
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| " + prefix, 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream row(line.substr(1));
    for (std::string cell; std::getline(row, cell, '|');) cells.push_back(cell.substr(1, cell.size() - 2));
    return cells;  // goal, measured, threshold, met, spp, M pixel-samples/s, M rays/s
  }
  return {};
}

TEST(AccuracyGoals, QuickRunMeasuresEveryGoalAgainstCachedReferences) {
  test::TempDir dir;
  const auto r = test::runProcess(
      {LENSFARM_ACCURACY_GOALS_BIN, "--quick", "--repeat", "2", "--threads", "2", "--cache", (dir / "cache").string()},
      60.0);
  ASSERT_EQ(r.exitCode, 0) << r.out << r.err;

  size_t references = 0;
  for (const auto& entry : fs::directory_iterator(dir / "cache")) references += entry.path().extension() == ".exr";
  EXPECT_EQ(references, 2u) << "cornell-classic and cornell-seed";

  const auto goal1 = tableRow(r.out, "1. "), job = tableRow(r.out, "2. Figure"), error = tableRow(r.out, "2. its"),
             goal3 = tableRow(r.out, "3. ");
  ASSERT_EQ(goal1.size(), 7u) << r.out;
  ASSERT_EQ(job.size(), 7u) << r.out;
  ASSERT_EQ(error.size(), 7u) << r.out;
  ASSERT_EQ(goal3.size(), 7u) << r.out;
  EXPECT_EQ(goal1[1].rfind(">", 0), std::string::npos) << "goal 1 reached its target: " << goal1[1];
  EXPECT_EQ(goal3[1].rfind(">", 0), std::string::npos) << "NEE + MIS reached the naive job's error: " << goal3[1];
  EXPECT_NE(job[0].find(" 65536 paths"), std::string::npos) << job[0];  // 64 spp at 32 x 32
  EXPECT_EQ(job[4], "64");
  const double naiveError = std::stod(error[1]);
  EXPECT_GT(naiveError, 5.0) << "per cent: 64 naive samples of a small light are noisy";
  EXPECT_LT(naiveError, 100.0);
  EXPECT_LT(std::stod(goal3[4]), 0.8 * 64) << "NEE + MIS needs fewer samples for the naive job's error";
  for (const auto* row : {&goal1, &job, &goal3}) {
    EXPECT_GT(std::stod((*row)[5]), 0.0) << "pixel-samples/s";
    EXPECT_GT(std::stod((*row)[6]), std::stod((*row)[5])) << "more than one ray per path";
  }
}

}  // namespace
}  // namespace lensfarm
