// A full disk under a real coordinator's state dir (a small tmpfs mounted for the test, filled
// to the last byte) while a real worker renders: the job stalls and says why with errno's text
// (never the state dir's path), the worker waits instead of rendering units again and again, and
// when space returns the job finishes with the local render's bits.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <filesystem>
#include <fstream>

#include "tests/farm/farm_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// A tmpfs of `megabytes` at `dir` for the life of the object.
class SmallDisk {
 public:
  SmallDisk(const fs::path& dir, int megabytes) : dir_(dir) {
    fs::create_directories(dir);
    const std::string options = "size=" + std::to_string(megabytes) + "m,mode=0700";
    mounted_ = ::mount("tmpfs", dir.c_str(), "tmpfs", 0, options.c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }

  // Fills the disk to the last byte with `file`; returns the bytes written.
  static size_t fill(const fs::path& file) {
    std::ofstream out(file, std::ios::binary);
    const std::string block(4096, 'x');
    size_t written = 0;
    while (out.write(block.data(), std::streamsize(block.size())) && out.flush()) written += block.size();
    return written;
  }

 private:
  fs::path dir_;
  bool mounted_ = false;
};

class FullDisk : public test::FarmFixture {};

TEST_F(FullDisk, AFullStateDirStallsTheJobWithItsErrnoAndItFinishesExactlyWhenSpaceReturns) {
  const fs::path state = dir_ / "state";
  SmallDisk disk(state, 64);
  ASSERT_TRUE(disk.mounted()) << "mounting a tmpfs needs root (CAP_SYS_ADMIN): " << std::strerror(errno);
  const fs::path scene = writeScene(64, 8, 2);  // 4 units of ~100 kB sums each
  const std::string address = startCoordinator("127.0.0.1:0", {"--state-dir", state.string()});
  const std::string job = submit(address, scene);
  const size_t filled = SmallDisk::fill(state / "filler");
  ASSERT_GT(filled, 0u);
  test::ChildProcess& worker = startWorker(address, "w1");

  // The job says it is stalled, and why, in `status`; never where the state dir is.
  std::string status;
  ASSERT_TRUE(test::waitFor(
      [&] {
        status = cli({"status", job, "--coordinator", address}).out;
        return test::contains(status, "stalled:") && test::contains(status, "No space left on device");
      },
      60))
      << status << coordinator_->log();
  EXPECT_TRUE(test::contains(status, "cannot write its state dir")) << status;
  EXPECT_FALSE(test::contains(status, state.string())) << "the state dir's path is the coordinator's own";
  EXPECT_TRUE(test::contains(coordinator_->log(), "No space left on device")) << "errno's text in the log";

  // The worker waits: over three seconds it uploads (and is refused) at most once more.
  const auto refusals = [&] {
    size_t n = 0;
    const std::string log = worker.log();
    for (size_t at = log.find("refused"); at != std::string::npos; at = log.find("refused", at + 1)) ++n;
    return n;
  };
  const size_t before = refusals();
  std::this_thread::sleep_for(std::chrono::seconds(3));  // the window the refusals are counted over
  EXPECT_LE(refusals(), before + 1) << worker.log();
  EXPECT_FALSE(test::contains(worker.log(), state.string() + "/"))
      << "the worker is not told the state dir's path: " << worker.log();

  // Space returns: the job finishes by itself, with the local render's bits.
  fs::remove(state / "filler");
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err << coordinator_->log();
  expectFarmImageIsTheLocalRender(address, job, scene, "a full disk on the way changes no bit");
}

}  // namespace
}  // namespace lensfarm
