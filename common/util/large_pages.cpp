#include "common/util/large_pages.h"

#include <fcntl.h>
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdlib>
#include <new>

namespace lensfarm {

namespace {

constexpr uint64_t kPageBytes = 4096;  // the order-0 block of /proc/buddyinfo (x86-64, arm64)

// Reads a small file into `buffer` (at most size - 1 bytes, NUL-terminated) without allocating;
// the bytes read, 0 if it cannot.
std::size_t readSmallFile(const char* path, char* buffer, std::size_t size) {
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  std::size_t got = 0;
  while (got + 1 < size) {
    const ssize_t n = ::read(fd, buffer + got, size - 1 - got);
    if (n <= 0) break;
    got += std::size_t(n);
  }
  ::close(fd);
  buffer[got] = '\0';
  return got;
}

// The kernel's huge page size for anonymous memory; 0 where it has none (no THP, or "never").
uint64_t hugePageBytes() {
  static const uint64_t bytes = [] {
    char text[256];
    if (readSmallFile("/sys/kernel/mm/transparent_hugepage/enabled", text, sizeof text) == 0) return uint64_t(0);
    if (std::string_view(text).find("[never]") != std::string_view::npos) return uint64_t(0);
    if (readSmallFile("/sys/kernel/mm/transparent_hugepage/hpage_pmd_size", text, sizeof text) == 0)
      return uint64_t(2) << 20;
    return uint64_t(std::strtoull(text, nullptr, 10));
  }();
  return bytes;
}

// glibc serves an allocation from a fresh mapping only above its mmap threshold, which it raises
// to the size of each large block freed (up to 32 MiB), after which frame-sized blocks come from
// its heap, already written or outside any advice. A fixed threshold keeps every allocation of
// kLargePageRequestBytes or more a mapping of its own, advised before anyone writes it.
[[maybe_unused]] const bool kFixedMmapThreshold = ::mallopt(M_MMAP_THRESHOLD, int(kLargePageRequestBytes)) == 1;

}  // namespace

uint64_t freeBytesInBlocks(std::string_view buddyinfo, uint64_t blockBytes) {
  uint64_t total = 0;
  while (!buddyinfo.empty()) {
    const std::size_t end = buddyinfo.find('\n');
    std::string_view line = buddyinfo.substr(0, end);
    buddyinfo = end == std::string_view::npos ? std::string_view() : buddyinfo.substr(end + 1);
    // "Node 0, zone   Normal   5823   7017 ...": the counts follow the zone's name.
    const std::size_t zone = line.find("zone");
    if (zone == std::string_view::npos) continue;
    line.remove_prefix(zone + 4);
    while (!line.empty() && line.front() == ' ') line.remove_prefix(1);
    while (!line.empty() && line.front() != ' ') line.remove_prefix(1);  // the zone's name
    uint64_t block = kPageBytes;
    while (!line.empty()) {
      while (!line.empty() && line.front() == ' ') line.remove_prefix(1);
      if (line.empty()) break;
      uint64_t count = 0;
      bool digits = false;
      while (!line.empty() && line.front() >= '0' && line.front() <= '9') {
        count = count * 10 + uint64_t(line.front() - '0');
        line.remove_prefix(1);
        digits = true;
      }
      if (!digits) return 0;  // not buddyinfo
      if (block >= blockBytes) total += count * block;
      block *= 2;
    }
  }
  return total;
}

void* allocateLargePages(std::size_t n) {
  const uint64_t huge = hugePageBytes();
  if (huge == 0 || n < huge) return nullptr;
  const std::size_t rounded = (n + huge - 1) / huge * huge;
  char text[4096];
  if (readSmallFile("/proc/buddyinfo", text, sizeof text) == 0) return nullptr;
  if (freeBytesInBlocks(std::string_view(text), huge) < 2 * uint64_t(rounded)) return nullptr;
  // Aligned, the whole block is huge pages: no 4 KiB pages at its ends. free() takes it back.
  void* p = std::aligned_alloc(huge, rounded);
  if (p) ::madvise(p, rounded, MADV_HUGEPAGE);
  return p;
}

}  // namespace lensfarm

// The replaceable global allocation function ([new.delete.single]); libstdc++'s array and nothrow
// forms call it. A large block in huge pages where the kernel has them free, else malloc's memory;
// the default operator delete frees either.
void* operator new(std::size_t n) {
  if (n == 0) n = 1;
  if (n >= lensfarm::kLargePageRequestBytes)
    if (void* p = lensfarm::allocateLargePages(n)) return p;
  for (;;) {
    if (void* p = std::malloc(n)) return p;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}
