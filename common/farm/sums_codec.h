#pragma once
// Lossless compression of a unit's per-cell sums for upload (worker_service.proto, SumsEncoding).
//
// A block of `count` doubles (IEEE 754 binary64, little-endian; at most kSumsBlockDoubles) is
// encoded as:
//  1. byte-plane shuffle: the 8·count bytes are reordered so that byte b (0 = least significant)
//     of double i lands at b·count + i: all bytes 0, then all bytes 1, ..., then all bytes 7. The
//     "shuffle" filter of Blosc and HDF5 (F. Alted, "Why Modern CPUs Are Starving and What Can Be
//     Done about It", CiSE 12(2), 2010; HDF5 H5Z_FILTER_SHUFFLE): the sign/exponent and high
//     mantissa bytes of neighbouring cells are alike, and grouped they form long runs that an LZ
//     coder finds, where interleaved with the noisy low mantissa bytes they do not.
//  2. zstd (RFC 8878): exactly one zstd frame holding the shuffled bytes, its header declaring the
//     content size (8·count), with a content checksum.
// Nothing else: no length prefix, no other framing. Decoding undoes both steps bit for bit (NaN
// payloads, -0.0 and subnormals included: bytes are moved, never interpreted).
//
// Decoding is for untrusted input: the frame's declared content size is checked against what the
// caller can take (the unit's region, known to the coordinator) before anything is decompressed,
// and a block that is not exactly one such frame, that is truncated, corrupt, or larger than
// declared, is refused with FarmError(kInvalidArgument) naming it; memory never grows with what a
// sender claims (a decompression bomb gets an error).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace lensfarm {

// How a worker uploads the sums (worker_service.proto SumsEncoding; same numbers).
enum class SumsEncoding : uint32_t {
  kRaw = 0,          // the doubles' little-endian bytes as they are
  kShuffleZstd = 1,  // blocks of at most kSumsBlockDoubles doubles, each shuffled and zstd-compressed
};

// At most this many doubles (512 KiB) in one block: any block's encoding is then under 1 MiB
// (ZSTD_compressBound(512 KiB) = 514 KiB), one gRPC message, and the decoder's scratch is bounded.
inline constexpr size_t kSumsBlockDoubles = size_t(1) << 16;
// zstd's level for uploads: 1, its fastest standard level (docs/performance.md, "Upload
// compression": higher levels shrink noisy sums by a few percent at a fraction of the speed).
inline constexpr int kSumsZstdLevel = 1;

// The encoding of values[0, count) (count <= kSumsBlockDoubles) as one block.
std::string encodeSumsBlock(const double* values, size_t count, int level = kSumsZstdLevel);

// Decodes one block into out[0, n) and returns n, the number of doubles its frame declares. Throws
// FarmError(kInvalidArgument) "<what>: ..." when the block is not one whole zstd frame declaring a
// content size of whole doubles, declares more than `capacity` doubles (or kSumsBlockDoubles), or
// does not decompress to exactly what it declares (truncated, corrupt, checksum mismatch).
size_t decodeSumsBlock(std::string_view block, double* out, size_t capacity, const std::string& what);

}  // namespace lensfarm
