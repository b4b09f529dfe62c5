// A writer killed mid-write leaves its temporary behind; the next write of the same target removes
// it, and removeStaleTemporaries clears a directory. A live writer's temporary and names that are
// no temporary stay. A failed write says why in its errno's words (common/util/atomic_file.h).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/util/atomic_file.h"
#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// The PID of a process that has exited and been reaped, as a killed writer's is (-1 if fork fails).
pid_t deadPid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  if (pid > 0) ::waitpid(pid, &status, 0);
  return pid;
}

std::string tmpOf(const std::string& target, pid_t pid) { return "." + target + ".tmp-" + std::to_string(pid); }

void writeText(const fs::path& path, const std::string& text) {
  writeFileAtomically(path, [&](const fs::path& tmp) { std::ofstream(tmp, std::ios::binary) << text; });
}

// The names in `dir` (not below it), sorted.
std::vector<std::string> namesIn(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The message of the InputError that writeFileAtomically(path, write) throws ("" if none).
std::string failureOf(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  try {
    writeFileAtomically(path, write);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(AtomicFile, AKilledWritersTemporaryIsRemovedByTheNextWrite) {
  test::TempDir dir;
  const pid_t dead = deadPid();
  ASSERT_GT(dead, 0);
  dir.write("img.exr", "the old image");
  dir.write(tmpOf("img.exr", dead), "half of an image");
  writeText(dir / "img.exr", "the new image");
  EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"img.exr"});
  EXPECT_EQ(test::readFile(dir / "img.exr"), "the new image");
}

TEST(AtomicFile, ALiveWritersTemporaryAndNamesThatAreNoTemporaryOfTheTargetAreKept) {
  test::TempDir dir;
  const pid_t dead = deadPid();
  ASSERT_GT(dead, 0);
  const std::vector<std::string> kept = {tmpOf("img.exr", ::getppid()),  // another writer, still writing
                                         ".img.exr.tmp-12ab", "img.exr.tmp-5", ".img.exr.tmp-0" + std::to_string(dead),
                                         tmpOf("other.exr", dead)};  // stale, but of another target
  for (const std::string& name : kept) dir.write(name, "someone's bytes");
  writeText(dir / "img.exr", "the new image");
  std::vector<std::string> expected = kept;
  expected.push_back("img.exr");
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(namesIn(dir.path()), expected);
  EXPECT_EQ(test::readFile(dir / "img.exr"), "the new image");
  for (const std::string& name : kept) EXPECT_EQ(test::readFile(dir / name), "someone's bytes") << name;
}

TEST(AtomicFile, RemovingStaleTemporariesClearsDeadWritersOfEveryTargetAndKeepsTheRest) {
  test::TempDir dir;
  const pid_t dead = deadPid();
  ASSERT_GT(dead, 0);
  const std::vector<std::string> stale = {tmpOf("img.exr", dead), tmpOf("other.exr", dead)};
  const std::vector<std::string> kept = {"img.exr", tmpOf("img.exr", ::getppid()), ".img.exr.tmp-12ab",
                                         "img.exr.tmp-5"};
  for (const std::string& name : stale) dir.write(name, "half of an image");
  for (const std::string& name : kept) dir.write(name, "bytes");
  dir.write("sub/" + tmpOf("deep.exr", dead), "half of an image");
  fs::create_directory(dir / tmpOf("a-directory", dead));  // only regular files are removed

  removeStaleTemporaries(dir.path(), false);
  std::vector<std::string> expected = kept;
  expected.push_back("sub");
  expected.push_back(tmpOf("a-directory", dead));
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(namesIn(dir.path()), expected);
  EXPECT_TRUE(fs::exists(dir / "sub" / tmpOf("deep.exr", dead))) << "not recursive: subdirectories are left alone";

  removeStaleTemporaries(dir.path(), true);
  EXPECT_EQ(namesIn(dir.path()), expected);
  EXPECT_TRUE(fs::is_empty(dir / "sub"));
  removeStaleTemporaries(dir / "no-such-directory", true);  // ignored, never throws
}

TEST(AtomicFile, AFailedWriteSaysWhyInTheWordsOfItsErrno) {
  test::TempDir dir;
  const fs::path target = dir.write("img.exr", "the old image");
  const std::string why = failureOf(target, [](const fs::path& tmp) {
    std::ofstream(tmp, std::ios::binary) << "part of an image";
    errno = ENOSPC;  // as a write to a full disk leaves it
    throw std::runtime_error("write failed");
  });
  EXPECT_EQ(why, target.string() + ": cannot write: write failed (No space left on device)");
  EXPECT_EQ(namesIn(dir.path()), std::vector<std::string>{"img.exr"}) << "no temporary remains";
  EXPECT_EQ(test::readFile(target), "the old image");
}

// The removal of a stale temporary before the write leaves ESRCH in errno (from kill); a failure
// that sets no errno must not be explained by it.
TEST(AtomicFile, AFailureThatSetsNoErrnoGetsNoSystemText) {
  test::TempDir dir;
  const pid_t dead = deadPid();
  ASSERT_GT(dead, 0);
  dir.write(tmpOf("img.exr", dead), "half of an image");
  const fs::path target = dir / "img.exr";
  const std::string why = failureOf(target, [](const fs::path&) { throw std::runtime_error("the encoder refused"); });
  EXPECT_EQ(why, target.string() + ": cannot write: the encoder refused");
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

}  // namespace
}  // namespace lensfarm
