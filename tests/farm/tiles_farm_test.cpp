// What the farm promises for a big still (docs/farm.md "Tiles and passes"): a 3840x2160 job on 8
// local worker processes over real gRPC. The image is `lensfarm render`'s, bit for bit; the bytes
// the coordinator receives are about one frame of sums, not one per worker; no single upload is
// more than an eighth of a frame-sized float buffer; and the coordinator's memory for the job
// stays under three frame-sized float buffers.
//
// Sizes: a frame-sized float buffer is W x H x 3 floats x 4 bytes (99.5 MB at 3840x2160). A tile's
// upload carries 3 doubles per cell (JobLayout::sumsOf), so its bytes are tile cells x 24.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/film/image_io.h"
#include "tests/deploy_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 3840, kHeight = 2160, kWorkers = 8;
constexpr double kFrameFloatBytes = double(kWidth) * kHeight * 3 * sizeof(float);

// A field of /proc/PID/status in bytes ("VmHWM", "VmRSS"; the kernel writes them in kB), or -1.
double procStatusBytes(int pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field + ":", 0) == 0) return 1024.0 * std::stod(line.substr(field.size() + 1));
  return -1.0;
}

// The value of `pattern`'s first group in `text`, or -1.
double numberIn(const std::string& text, const std::string& pattern) {
  std::smatch m;
  return std::regex_search(text, m, std::regex(pattern)) ? std::stod(m[1]) : -1.0;
}

TEST(TilesFarm, A4kJobOnEightWorkersIsTheLocalRenderWithBoundedUploadsAndMemory) {
  test::TempDir dir;
  test::FarmProcesses farm(dir);
  // The cheapest 4K image that still has structure: a lit quad and a visible light, one bounce,
  // one sample per pixel.
  nlohmann::json scene = test::minimalSceneJson();
  scene["lights"][0]["visible_to_camera"] = true;
  scene["render"]["resolution"] = {kWidth, kHeight};
  scene["render"]["samples_per_pixel"] = 1;
  scene["render"]["max_bounces"] = 1;
  const fs::path file = dir.write("scene.json", scene.dump(2));

  const std::string address =
      farm.startCoordinator({"--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0", "--heartbeat-interval",
                             "0.2", "--lease-timeout", "30", "--state-dir", (dir / "state").string()});
  const auto metrics = [&] { return test::parseMetrics(test::httpGet(farm.metricsAddress(), "/metrics")); };
  for (int i = 0; i < kWorkers; ++i)
    farm.startWorker("w" + std::to_string(i), {"--coordinator", address, "--threads", "1"});
  // The layout is chosen from the workers connected at submission: wait for all eight.
  ASSERT_TRUE(test::waitFor([&] { return metrics()["lensfarm_workers_alive"] == kWorkers; }, 60))
      << farm.coordinator().log();

  const int coordinatorPid = farm.coordinator().pid();
  const double rssBefore = procStatusBytes(coordinatorPid, "VmRSS");
  ASSERT_GT(rssBefore, 0.0);
  const std::string job = farm.submit({file.string(), "--coordinator", address});
  const auto watched = farm.cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err << farm.cli({"status", job, "--coordinator", address}).out
                                 << farm.coordinator().log();
  // VmHWM is the process's peak resident set since it started; the job's share is the rise over
  // the resident set just before the submit.
  const double peak = procStatusBytes(coordinatorPid, "VmHWM");
  const fs::path farmExr = dir / "farm.exr";
  const auto downloaded = farm.cli({"download", job, "-o", farmExr.string(), "--coordinator", address});
  ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;
  const double peakWithDownload = procStatusBytes(coordinatorPid, "VmHWM");
  // The decoded sums (what the bound is about); the bytes on the wire may be fewer (compressed).
  const auto counters = metrics();
  const double bytesIn = counters.at("lensfarm_received_bytes_total{kind=\"unit\"}");
  const double wireBytes = counters.at("lensfarm_unit_wire_bytes_total");
  const std::string status = farm.cli({"status", job, "--coordinator", address}).out;

  // (a) Bit for bit the in-process render of the same scene.
  const fs::path localExr = dir / "local.exr";
  const auto local = farm.cli({"render", file.string(), "-o", localExr.string(), "--threads", "2", "-q"});
  ASSERT_EQ(local.exitCode, 0) << local.err;
  ImageMetadata farmMeta, localMeta;
  const Image farmImage = readExr(farmExr, &farmMeta);
  const Image localImage = readExr(localExr, &localMeta);
  ASSERT_EQ(farmImage.width, kWidth);
  ASSERT_EQ(farmImage.height, kHeight);
  EXPECT_EQ(farmMeta.totalSamples, uint64_t(kWidth) * kHeight) << "every cell's one sample, once";
  EXPECT_TRUE(farmImage.rgb == localImage.rgb) << "the farm's 4K image equals `lensfarm render`'s";

  // (b) Bytes in: each cell's sums cross the network once, so about 2 frame-sized float buffers
  // (doubles), far under one per worker.
  EXPECT_GT(bytesIn, 0.0);
  EXPECT_LE(bytesIn, kFrameFloatBytes * kWorkers * 1.1);

  // (c) The largest upload. No metric reports it: it is one tile's sums, from the layout the job
  // reports (`status`: "tiles: N px, T a frame"); a full tile is the largest.
  const double tileEdge = numberIn(status, R"(tiles: +([0-9]+) px)");
  const double tilesPerFrame = numberIn(status, R"(tiles: +[0-9]+ px, ([0-9]+) a frame)");
  ASSERT_GT(tileEdge, 0.0) << "a 4K still on 8 workers is tiled:\n" << status;
  const double largestUpload = tileEdge * tileEdge * 3 * sizeof(double);
  EXPECT_LE(largestUpload, kFrameFloatBytes / 8);
  EXPECT_GE(tilesPerFrame, 4.0 * kWorkers) << "at least four tiles a worker (resolveTileSize)";
  // Every cell's sums arrived (audits, docs/farm.md "Audit", add a few tiles more).
  EXPECT_GE(bytesIn, double(kWidth) * kHeight * 3 * sizeof(double));

  // (d) The coordinator's memory for the active job (submit to done); serving the download after
  // is reported, not bounded here.
  ASSERT_GT(peak, 0.0);
  EXPECT_LE(peak - rssBefore, 3 * kFrameFloatBytes);

  std::printf(
      "4K on %d workers: tile %g px (%g a frame); bytes in %.1f MB (limit %.1f MB; %.1f MB on the wire); largest "
      "upload %.2f MB (limit %.2f MB); coordinator RSS before %.1f MB, peak %.1f MB, rise %.1f MB (limit %.1f MB); "
      "peak after the download %.1f MB\n",
      kWorkers, tileEdge, tilesPerFrame, bytesIn / 1e6, kFrameFloatBytes * kWorkers * 1.1 / 1e6, wireBytes / 1e6,
      largestUpload / 1e6, kFrameFloatBytes / 8 / 1e6, rssBefore / 1e6, peak / 1e6, (peak - rssBefore) / 1e6,
      3 * kFrameFloatBytes / 1e6, peakWithDownload / 1e6);
  RecordProperty("unit_bytes_received", std::to_string(bytesIn));
  RecordProperty("largest_upload_bytes", std::to_string(largestUpload));
  RecordProperty("coordinator_memory_rise_bytes", std::to_string(peak - rssBefore));
}

}  // namespace
}  // namespace lensfarm
