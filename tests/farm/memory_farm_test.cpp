// Memory with the real binaries (docs/farm.md, "Memory"): a farm coordinator refuses a job over
// --max-job-memory with RESOURCE_EXHAUSTED naming the estimate and keeps serving; `lensfarm
// render` refuses a render this machine cannot hold before tracing, exit 2, writing nothing.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>

#include "common/farm/memory_estimate.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::contains;
using json = nlohmann::json;

using test::kBadInput;

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

test::ProcessResult cli(std::vector<std::string> args, const std::string& env = "") {
  args.insert(args.begin(), test::cliPath().string());
  if (!env.empty()) args.insert(args.begin(), {"/usr/bin/env", env});
  return test::runProcess(args, 120);
}

TEST(FarmMemory, ASubmitOverTheBudgetIsRefusedWithItsEstimateAndTheCoordinatorGoesOn) {
  test::TempDir dir;
  const fs::path portFile = dir / "port";
  test::ChildProcess coordinator({test::coordinatorPath(), "--listen", "127.0.0.1:0", "--port-file", portFile.string(),
                                  "--heartbeat-interval", "0.2", "--max-job-memory", "300M"},
                                 dir / "coordinator");
  ASSERT_TRUE(test::waitFor([&] { return fs::exists(portFile) || !coordinator.running(); }, 30)) << coordinator.log();
  std::string address = test::readFile(portFile);
  address.erase(address.find_last_not_of("\n") + 1);
  ASSERT_FALSE(address.empty()) << coordinator.log();
  test::ChildProcess worker({test::workerPath(), "--coordinator", address, "--threads", "1", "--name", "w",
                             "--cache-dir", "", "--max-backoff", "0.3"},
                            dir / "worker");
  const std::string scene = (test::scenesDir() / "cornell-seed.json").string();

  const auto refused = cli({"submit", scene, "--coordinator", address, "--resolution", "16384x16384", "--spp", "4"});
  EXPECT_EQ(refused.exitCode, kBadInput) << refused.err;
  EXPECT_TRUE(refused.out.empty()) << refused.out;
  EXPECT_TRUE(contains(refused.err, "16384x16384"));
  EXPECT_TRUE(contains(refused.err, "needs an estimated "));
  EXPECT_TRUE(std::regex_search(refused.err, std::regex("estimated [0-9.]+ GB of coordinator memory"))) << refused.err;
  EXPECT_TRUE(contains(refused.err, "315 MB allowed per job (--max-job-memory)"));
  EXPECT_TRUE(coordinator.running()) << coordinator.log();

  // The same coordinator serves the next job to the end.
  const auto submitted = cli({"submit", scene, "--coordinator", address, "--resolution", "32x32", "--spp", "4"});
  ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
  std::string job = submitted.out;
  job.erase(job.find_last_not_of("\n") + 1);
  const auto watched = cli({"watch", job, "--coordinator", address});
  EXPECT_EQ(watched.exitCode, 0) << watched.err;
  const auto status = cli({"status", "--coordinator", address});
  EXPECT_EQ(status.exitCode, 0);
  EXPECT_FALSE(contains(status.out, "16384")) << "the refused job was never queued";
  EXPECT_TRUE(coordinator.running());
}

TEST(FarmMemory, AMalformedBudgetIsABadFlag) {
  const auto r =
      test::runProcess({test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--max-job-memory", "lots"}, 30);
  EXPECT_EQ(r.exitCode, kBadInput) << r.err;
  EXPECT_TRUE(contains(r.err, "--max-job-memory"));
}

TEST(CliMemory, ARenderOverTheBudgetIsRefusedBeforeTracingAndWritesNothing) {
  test::TempDir out;
  const std::string scene = (test::scenesDir() / "cornell-seed.json").string();
  const fs::path exr = out / "big.exr";
  {
    SCOPED_TRACE("--resolution");
    const auto r = cli({"render", scene, "-o", exr.string(), "--resolution", "3840x2160", "--spp", "1", "-q"},
                       "LENSFARM_MAX_JOB_MEMORY=100M");
    EXPECT_FALSE(r.timedOut);
    EXPECT_EQ(r.exitCode, kBadInput) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_TRUE(contains(r.err, "error: --resolution: a 3840x2160 render needs an estimated 979 MB of memory"));
    EXPECT_TRUE(contains(r.err, "sensor 398 MB"));
    EXPECT_TRUE(contains(r.err, "105 MB allowed per job (LENSFARM_MAX_JOB_MEMORY)"));
    EXPECT_TRUE(entries(out.path()).empty());
  }
  {
    SCOPED_TRACE("the scene's resolution");
    json big = test::bundledSceneJson("cornell-seed.json");
    big["render"]["resolution"] = {4000, 3000};
    const fs::path file = out.write("big-scene.json", big.dump(2));
    const auto r = cli({"render", file.string(), "-o", exr.string(), "-q"}, "LENSFARM_MAX_JOB_MEMORY=1G");
    EXPECT_EQ(r.exitCode, kBadInput) << r.err;
    EXPECT_TRUE(contains(r.err, "big-scene.json: render.resolution: a 4000x3000 render needs an estimated 1.42 GB"));
    fs::remove(file);
    EXPECT_TRUE(entries(out.path()).empty());
  }
  {
    SCOPED_TRACE("a malformed budget");
    const auto r =
        cli({"render", scene, "-o", exr.string(), "--resolution", "16x16", "-q"}, "LENSFARM_MAX_JOB_MEMORY=plenty");
    EXPECT_EQ(r.exitCode, kBadInput) << r.err;
    EXPECT_TRUE(contains(r.err, "LENSFARM_MAX_JOB_MEMORY"));
    EXPECT_TRUE(entries(out.path()).empty());
  }
}

}  // namespace
}  // namespace lensfarm
