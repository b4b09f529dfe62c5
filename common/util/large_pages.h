#pragma once
// Large pages for frame-sized memory (docs/performance.md, "Everything around the render").
//
// A 1080p frame's buffers are hundreds of megabytes (the coordinator's compensated sums and
// convergence tracker, 72 bytes a pixel; a unit's sums; the developed image), written once from
// zero. With 4 KiB pages each first write of a page is a fault: 37,000 faults for 150 MB, about
// 0.4 s on a virtual machine where a fault costs 11 us. A transparent huge page (2 MiB on x86-64)
// replaces 512 of them. Kernels in the "madvise" mode (Debian's default) give huge pages only to
// memory that asks with madvise(MADV_HUGEPAGE), and then, when no free 2 MiB block is at hand,
// compact memory in the faulting thread: a stall of hundreds of milliseconds on a fragmented
// machine. So memory asks only when the buddy allocator already holds enough free blocks of that
// size (/proc/buddyinfo) for the request twice over: never a compaction, only fewer faults.
//
// The process's global operator new (large_pages.cpp) allocates every block of at least
// kLargePageRequestBytes so (allocateLargePages), in every binary linking lensfarm_util, each a
// fresh mapping of its own (malloc's mmap threshold is fixed there, so freed frames go back to
// the kernel rather than into malloc's heap); delete is the default (free). Nothing else
// changes: the memory and its contents are what malloc gives, so no bit of an image does.
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace lensfarm {

// Allocations this large ask for huge pages (one at least, for the 2 MiB-aligned part).
inline constexpr std::size_t kLargePageRequestBytes = std::size_t(4) << 20;

// The bytes held in free blocks of at least `blockBytes` (a power of two times the 4 KiB page)
// according to `buddyinfo`, text in the format of /proc/buddyinfo ("Node 0, zone Normal 5 3 ...":
// the free blocks of each order 0, 1, ..., a block of order k being 2^k pages). 0 for text it
// cannot read.
uint64_t freeBytesInBlocks(std::string_view buddyinfo, uint64_t blockBytes);

// At least n bytes from malloc (free() takes them back), 2 MiB-aligned and n rounded up to 2 MiB,
// advised to be huge pages before anyone writes them, if the kernel has free 2 MiB blocks for
// twice that (read from /proc/buddyinfo); nullptr if it has not (or has no transparent huge
// pages). The rounding costs at most one huge page more than n once written.
void* allocateLargePages(std::size_t n);

}  // namespace lensfarm
