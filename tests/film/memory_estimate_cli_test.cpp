// The memory estimate (render/memory_estimate.h) against the peak RSS of a real `lensfarm render`:
// runs the real `lensfarm` binary.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "common/farm/memory_estimate.h"
#include "tests/film/memory_estimate_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using test::settingsOf;

// Peak RSS (ru_maxrss) of a real `lensfarm render` child, in bytes.
uint64_t peakRssOfRender(const std::vector<std::string>& args, int* exitCode) {
  test::TempDir dir;
  std::vector<std::string> argv = {test::cliPath().string(), "render"};
  argv.insert(argv.end(), args.begin(), args.end());
  const int pid = test::startProcess(argv, dir / "out.txt", dir / "err.txt");
  int status = 0;
  struct rusage usage {};
  ::wait4(pid, &status, 0, &usage);
  *exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (*exitCode != 0) ADD_FAILURE() << test::readFile(dir / "err.txt");
  return uint64_t(usage.ru_maxrss) * 1024;
}

TEST(MemoryEstimate, ARealRenderPeaksAtTheEstimate) {
  test::TempDir out;
  const fs::path scene = test::scenesDir() / "cornell-seed.json";
  int code = 0;
  // The process without a frame: libraries, the scene, its BVH, threads.
  const uint64_t base = peakRssOfRender({scene.string(), "-o", (out / "tiny.exr").string(), "--resolution", "16x16",
                                         "--spp", "1", "--threads", "2", "-q"},
                                        &code);
  ASSERT_EQ(code, 0);
  const int w = 1920, h = 1080;
  const uint64_t peak =
      peakRssOfRender({scene.string(), "-o", (out / "hd.exr").string(), "-o", (out / "hd.png").string(), "--resolution",
                       "1920x1080", "--spp", "1", "--threads", "2", "-q"},
                      &code);
  ASSERT_EQ(code, 0);
  const uint64_t cells = uint64_t(w) * h;
  const uint64_t frame = peak - std::min(peak, base);
  const uint64_t estimate = localRenderMemory(settingsOf(w, h), 0).total();
  // The estimate bounds what the frame costs, and is not far above it: the sensor, the tracker
  // and the unit buffer are all resident at once while a unit is summed (100 bytes a pixel).
  EXPECT_LE(frame, estimate) << "peak " << formatBytes(peak) << ", base " << formatBytes(base) << ", estimate "
                             << formatBytes(estimate);
  EXPECT_GE(frame, cells * (kSensorBytesPerCell + kTrackerBytesPerCell + kUnitBufferBytesPerCell) * 9 / 10)
      << "peak " << formatBytes(peak) << ", base " << formatBytes(base);
}

}  // namespace
}  // namespace lensfarm
