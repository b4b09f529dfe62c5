// Large pages for frame-sized memory (util/large_pages.h): /proc/buddyinfo read as the kernel
// writes it, and an allocation of a frame's size through operator new asks for huge pages when
// the kernel has free 2 MiB blocks for it (aligned to them), and a small one never does.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "common/util/large_pages.h"

namespace lensfarm {
namespace {

// This kernel's text (6.1, a 24 GiB machine): orders 0..10, a block of order k 2^k 4 KiB pages.
constexpr const char* kBuddyinfo =
    "Node 0, zone      DMA      0      0      0      0      0      0      0      0      1      1      3 \n"
    "Node 0, zone    DMA32      4      1      2      2      2      2      1      4      4      2    752 \n"
    "Node 0, zone   Normal   5823   7017   3438   2036   2462   2074   1135    731    394    304   2849 \n";

TEST(LargePages, BuddyinfoCountsTheBytesInBlocksOfAtLeastTheSize) {
  const uint64_t mib = uint64_t(1) << 20;
  // 2 MiB blocks are order 9, 4 MiB order 10: (1 + 2 + 304) x 2 MiB + (3 + 752 + 2849) x 4 MiB.
  EXPECT_EQ(freeBytesInBlocks(kBuddyinfo, 2 * mib), (1 + 2 + 304) * 2 * mib + (3 + 752 + 2849) * 4 * mib);
  EXPECT_EQ(freeBytesInBlocks(kBuddyinfo, 4 * mib), (3 + 752 + 2849) * 4 * mib);
  EXPECT_EQ(freeBytesInBlocks(kBuddyinfo, 8 * mib), 0u);
  // Order 0 counts every free page once.
  EXPECT_EQ(freeBytesInBlocks("Node 0, zone Normal 3 1\n", 4096), 3u * 4096 + 1u * 8192);
  EXPECT_EQ(freeBytesInBlocks("", 2 * mib), 0u);
  EXPECT_EQ(freeBytesInBlocks("Node 0, zone Normal 3 x 1\n", 4096), 0u) << "not buddyinfo: nothing";
}

// The VmFlags of the mapping holding `address` in /proc/self/smaps ("hg": MADV_HUGEPAGE asked).
std::string vmFlagsOf(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    unsigned long lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
      inside = uintptr_t(address) >= lo && uintptr_t(address) < hi;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line;
  }
  return "";
}

bool hugePagesAdvisable() {
  std::ifstream enabled("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(enabled, mode);
  std::ifstream buddy("/proc/buddyinfo");
  const std::string text((std::istreambuf_iterator<char>(buddy)), std::istreambuf_iterator<char>());
  return !mode.empty() && mode.find("[never]") == std::string::npos &&
         freeBytesInBlocks(text, uint64_t(2) << 20) > (uint64_t(256) << 20);
}

TEST(LargePages, AFrameSizedAllocationAsksForHugePagesAndASmallOneDoesNot) {
  if (!hugePagesAdvisable()) GTEST_SKIP() << "this kernel has no free 2 MiB blocks or no transparent huge pages";
  // 64 MiB of doubles, as a frame's sums are held.
  std::vector<double> frame(size_t(8) << 20, 0.0);
  const void* middle = frame.data() + frame.size() / 2;
  EXPECT_NE(vmFlagsOf(middle).find(" hg"), std::string::npos) << vmFlagsOf(middle);
  EXPECT_EQ(uintptr_t(frame.data()) % (uintptr_t(2) << 20), 0u) << "aligned, no 4 KiB pages at its start";
  // Below kLargePageRequestBytes: malloc's memory as it is.
  auto small = std::make_unique<char[]>(kLargePageRequestBytes / 2);
  EXPECT_EQ(vmFlagsOf(small.get()).find(" hg"), std::string::npos) << vmFlagsOf(small.get());
}

}  // namespace
}  // namespace lensfarm
