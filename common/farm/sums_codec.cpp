#include "common/farm/sums_codec.h"

#include <zstd.h>

#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

#include "common/farm/farm_types.h"

namespace lensfarm {

static_assert(sizeof(double) == 8 && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the shuffle moves the bytes of little-endian IEEE doubles as they lie in memory");

static_assert(ZSTD_COMPRESSBOUND(kSumsBlockDoubles * sizeof(double)) < (size_t(1) << 20),
              "an encoded block fits in a 1 MiB message whatever the doubles");

namespace {

constexpr size_t kBytes = sizeof(double);

// One compression and one decompression context per thread, reused (creating one allocates
// hundreds of KiB); gRPC serves an upload on one thread at a time.
struct CCtxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

ZSTD_DCtx* decompressor() {
  thread_local std::unique_ptr<ZSTD_DCtx, DCtxFree> d;
  if (!d) {
    d.reset(ZSTD_createDCtx());
    if (!d) throw std::bad_alloc();
    // A block decodes into at most 512 KiB: a frame asking for a larger window is refused
    // (ZSTD_error_frameParameter_windowTooLarge) instead of allocated.
    ZSTD_DCtx_setParameter(d.get(), ZSTD_d_windowLogMax, 20);
  }
  return d.get();
}

[[noreturn]] void refuse(const std::string& what, const std::string& why) {
  throw FarmError(FarmError::Kind::kInvalidArgument, what + ": " + why);
}

}  // namespace

std::string encodeSumsBlock(const double* values, size_t count, int level) {
  if (count > kSumsBlockDoubles)
    throw std::invalid_argument("encodeSumsBlock: " + std::to_string(count) + " doubles; a block holds at most " +
                                std::to_string(kSumsBlockDoubles));
  // Byte plane b of the block holds byte b of every double (sums_codec.h).
  std::vector<unsigned char> shuffled(count * kBytes);
  const auto* in = reinterpret_cast<const unsigned char*>(values);
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < kBytes; ++b) shuffled[b * count + i] = in[i * kBytes + b];

  thread_local std::unique_ptr<ZSTD_CCtx, CCtxFree> c;
  if (!c) {
    c.reset(ZSTD_createCCtx());
    if (!c) throw std::bad_alloc();
  }
  ZSTD_CCtx_reset(c.get(), ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(c.get(), ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(c.get(), ZSTD_c_contentSizeFlag, 1);
  ZSTD_CCtx_setParameter(c.get(), ZSTD_c_checksumFlag, 1);
  std::string block(ZSTD_compressBound(shuffled.size()), '\0');
  const size_t n = ZSTD_compress2(c.get(), block.data(), block.size(), shuffled.data(), shuffled.size());
  if (ZSTD_isError(n)) throw std::runtime_error(std::string("encodeSumsBlock: zstd: ") + ZSTD_getErrorName(n));
  block.resize(n);
  return block;
}

size_t decodeSumsBlock(std::string_view block, double* out, size_t capacity, const std::string& what) {
  // Exactly one frame, nothing after it (a skippable frame, a second frame or trailing bytes are
  // not the format).
  const size_t frame = ZSTD_findFrameCompressedSize(block.data(), block.size());
  if (ZSTD_isError(frame))
    refuse(what, std::string("not a whole zstd frame (") + ZSTD_getErrorName(frame) + ", " +
                     std::to_string(block.size()) + " bytes)");
  if (frame != block.size())
    refuse(what,
           std::to_string(block.size() - frame) + " bytes after the zstd frame's end at byte " + std::to_string(frame));
  const unsigned long long declared = ZSTD_getFrameContentSize(block.data(), block.size());
  if (declared == ZSTD_CONTENTSIZE_UNKNOWN || declared == ZSTD_CONTENTSIZE_ERROR)
    refuse(what, "the zstd frame does not declare its content size");
  if (declared % kBytes != 0) refuse(what, "declares " + std::to_string(declared) + " bytes, not whole doubles");
  const size_t most = std::min(capacity, kSumsBlockDoubles);
  if (declared / kBytes > most)
    refuse(what, "declares " + std::to_string(declared / kBytes) + " doubles; at most " + std::to_string(most) +
                     " fit here (" + std::to_string(capacity) + " left of the unit, " +
                     std::to_string(kSumsBlockDoubles) + " a block)");
  const size_t count = size_t(declared / kBytes);

  // Decompressed into a buffer of exactly the declared size: zstd stops with an error rather than
  // write past it, and the content checksum (when the frame has one) is verified.
  std::vector<unsigned char> shuffled(count * kBytes);
  const size_t n = ZSTD_decompressDCtx(decompressor(), shuffled.data(), shuffled.size(), block.data(), block.size());
  if (ZSTD_isError(n)) refuse(what, std::string("corrupt zstd frame: ") + ZSTD_getErrorName(n));
  if (n != shuffled.size())
    refuse(what, "the zstd frame holds " + std::to_string(n) + " bytes; it declares " + std::to_string(declared));

  auto* dst = reinterpret_cast<unsigned char*>(out);
  for (size_t i = 0; i < count; ++i)
    for (size_t b = 0; b < kBytes; ++b) dst[i * kBytes + b] = shuffled[b * count + i];
  return count;
}

}  // namespace lensfarm
