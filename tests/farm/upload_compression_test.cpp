// Compressed uploads through a real farm (worker_service.proto, SumsEncoding): a coordinator that
// asks for shuffle + zstd and one that asks for raw sums give the same image, bit for bit, and
// `lensfarm render`'s; the compressed farm moves fewer bytes over the wire than it decodes.
#include <gtest/gtest.h>

#include "common/film/image_io.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

struct FarmRun {
  Image image;
  double wireBytes = 0, decodedBytes = 0, unitsDone = 0;
};

// One coordinator (--upload-encoding `encoding`) and one worker render `scene` to the end.
FarmRun runFarm(const std::string& encoding, const std::filesystem::path& scene) {
  test::TempDir dir;
  test::FarmProcesses farm(dir);
  const std::string address =
      farm.startCoordinator({"--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0", "--heartbeat-interval",
                             "0.2", "--lease-timeout", "5", "--upload-encoding", encoding});
  farm.startWorker("w1", {"--coordinator", address, "--threads", "2"});
  const std::string job = farm.submit({scene.string(), "--coordinator", address});
  const test::ProcessResult watched = farm.cli({"watch", job, "--coordinator", address});
  EXPECT_EQ(watched.exitCode, 0) << watched.err << farm.coordinator().log();
  const std::filesystem::path out = dir / "farm.exr";
  const test::ProcessResult downloaded = farm.cli({"download", job, "-o", out.string(), "--coordinator", address});
  EXPECT_EQ(downloaded.exitCode, 0) << downloaded.err;
  FarmRun run;
  ImageMetadata metadata;
  run.image = readExr(out, &metadata);
  const auto metrics = test::parseMetrics(test::httpGet(farm.metricsAddress(), "/metrics"));
  run.wireBytes = metrics.at("lensfarm_unit_wire_bytes_total");
  run.decodedBytes = metrics.at("lensfarm_received_bytes_total{kind=\"unit\"}");
  run.unitsDone = metrics.at("lensfarm_units_done_total");
  return run;
}

TEST(UploadCompressionFarm, CompressedUploadsGiveTheSameImageForFewerBytes) {
  test::TempDir dir;
  // 160 x 160 cells: 76800 doubles a unit, two blocks of a compressed upload; 2 units.
  const std::filesystem::path scene = test::writeSeedScene(dir, 160, 4, 2);
  const FarmRun raw = runFarm("raw", scene);
  const FarmRun zstd = runFarm("shuffle-zstd", scene);

  const double unitBytes = 160.0 * 160.0 * 3 * sizeof(double);
  EXPECT_EQ(raw.unitsDone, 2.0);
  EXPECT_EQ(zstd.unitsDone, 2.0);
  EXPECT_EQ(raw.decodedBytes, 2 * unitBytes);
  EXPECT_EQ(raw.wireBytes, raw.decodedBytes) << "raw sums go over the wire as they are";
  EXPECT_EQ(zstd.decodedBytes, 2 * unitBytes);
  EXPECT_GT(zstd.wireBytes, 0.0);
  EXPECT_LT(zstd.wireBytes, zstd.decodedBytes * 0.8) << "compressed on the wire";

  ASSERT_EQ(raw.image.rgb.size(), zstd.image.rgb.size());
  EXPECT_TRUE(raw.image.rgb == zstd.image.rgb) << "the same image, bit for bit";
  test::FarmProcesses local(dir);
  const std::filesystem::path out = dir / "local.exr";
  const test::ProcessResult r = local.cli({"render", scene.string(), "-o", out.string(), "--threads", "2", "-q"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ImageMetadata metadata;
  EXPECT_TRUE(readExr(out, &metadata).rgb == zstd.image.rgb) << "and `lensfarm render`'s";
}

}  // namespace
}  // namespace lensfarm
