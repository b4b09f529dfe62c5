// The upload codec (farm/sums_codec.h): byte-plane shuffle + zstd gives every bit back, on rendered
// unit buffers and on doubles chosen to break a codec that interprets them; and every block that
// is not what the format says (truncated, corrupt, oversized, a bomb) is one clear error.
#include "common/farm/sums_codec.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>
#include <zstd.h>

#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/farm/farm_types.h"
#include "common/render/render_scene.h"
#include "common/render/unit_renderer.h"
#include "common/scene/scene_loader.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

double fromBits(uint64_t bits) {
  double d;
  std::memcpy(&d, &bits, sizeof d);
  return d;
}

// Encodes `values` block by block and decodes them back; true if every bit came back.
bool roundTrips(const std::vector<double>& values) {
  std::vector<double> back(values.size(), 1.0);
  size_t at = 0;
  for (size_t offset = 0; offset < values.size(); offset += kSumsBlockDoubles) {
    const size_t n = std::min(kSumsBlockDoubles, values.size() - offset);
    const std::string block = encodeSumsBlock(values.data() + offset, n);
    EXPECT_LT(block.size(), size_t(1) << 20) << "a block fits one 1 MiB message";
    at += decodeSumsBlock(block, back.data() + at, back.size() - at, "block");
  }
  return at == values.size() && std::memcmp(back.data(), values.data(), values.size() * sizeof(double)) == 0;
}

// The sums of one whole-frame unit of cornell-seed at 96x96 (27648 doubles).
std::vector<double> renderedSums(uint32_t spp) {
  Scene scene = loadScene(test::scenesDir() / "cornell-seed.json");
  scene.render.width = scene.render.height = 96;
  const RenderScene rs(scene);
  SensorBuffer buffer;
  PathStats stats;
  tbb::task_arena(2).execute([&] { renderUnit(rs, WorkUnit{0, 0, spp}, buffer, stats); });
  return buffer.sums;
}

// The FarmError a decode throws, or "" if it decoded.
std::string decodeError(std::string_view block, size_t capacity = kSumsBlockDoubles) {
  std::vector<double> out(std::min(capacity, kSumsBlockDoubles));
  try {
    decodeSumsBlock(block, out.data(), capacity, "the block at offset 7");
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("the block at offset 7: "), std::string::npos) << e.what();
    return e.what();
  }
  return "";
}

TEST(SumsCodec, RenderedUnitsComeBackBitForBitAndSmaller) {
  for (uint32_t spp : {1u, 16u}) {
    SCOPED_TRACE(spp);
    const std::vector<double> sums = renderedSums(spp);
    ASSERT_EQ(sums.size(), 96u * 96u * 3u);
    EXPECT_TRUE(roundTrips(sums));
    const std::string block = encodeSumsBlock(sums.data(), sums.size());
    // Rendered sums compress (measured 1.6x to 5x, docs/performance.md); random bits do not.
    EXPECT_LT(block.size(), sums.size() * sizeof(double) * 3 / 4);
  }
}

TEST(SumsCodec, EveryBitPatternComesBack) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> zeros = {0.0, -0.0, 0.0, -0.0};
  const std::vector<double> nans = {nan, -nan, fromBits(0x7ff0000000000001) /* signalling */,
                                    fromBits(0x7ff8dead0000beef), fromBits(0xfffffffffffffffe)};
  const std::vector<double> subnormals = {std::numeric_limits<double>::denorm_min(), fromBits(0x000fffffffffffff),
                                          -fromBits(0x0000000000000123)};
  const std::vector<double> extremes = {
      inf, -inf, std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(), 1.0, 1.0 + 1e-16};
  std::vector<double> special;
  for (const auto* group : {&zeros, &nans, &subnormals, &extremes}) {
    EXPECT_TRUE(roundTrips(*group));
    special.insert(special.end(), group->begin(), group->end());
  }
  EXPECT_TRUE(roundTrips(special));
  EXPECT_TRUE(roundTrips({-0.0}));
  EXPECT_TRUE(roundTrips(std::vector<double>(kSumsBlockDoubles, 0.0))) << "all zero, a full block";
  EXPECT_TRUE(roundTrips(std::vector<double>(kSumsBlockDoubles * 2 + 5, -0.0))) << "several blocks";

  std::mt19937_64 random(24);
  std::vector<double> bits(kSumsBlockDoubles + 3);
  for (double& d : bits) d = fromBits(random());
  EXPECT_TRUE(roundTrips(bits)) << "random bits (NaNs of every payload among them)";
  // Incompressible input stays within one message: shuffled random bits grow by zstd's framing only.
  EXPECT_LE(encodeSumsBlock(bits.data(), kSumsBlockDoubles).size(),
            ZSTD_compressBound(kSumsBlockDoubles * sizeof(double)));
}

TEST(SumsCodec, TheLayoutIsTheFormatTheProtoDescribes) {
  // Two doubles, shuffled: byte b of double i at b * 2 + i; then one plain zstd frame, which any
  // zstd decoder reads (here libzstd's simple API, not the codec).
  const std::vector<double> v = {fromBits(0x0807060504030201), fromBits(0x1817161514131211)};
  const std::string block = encodeSumsBlock(v.data(), v.size());
  ASSERT_EQ(ZSTD_getFrameContentSize(block.data(), block.size()), 16u);
  std::string plain(16, '\0');
  ASSERT_EQ(ZSTD_decompress(plain.data(), plain.size(), block.data(), block.size()), 16u);
  EXPECT_EQ(plain, std::string("\x01\x11\x02\x12\x03\x13\x04\x14\x05\x15\x06\x16\x07\x17\x08\x18", 16));
}

TEST(SumsCodec, TruncatedCorruptAndForeignBlocksAreRefused) {
  const std::vector<double> sums = renderedSums(2);
  const std::string block = encodeSumsBlock(sums.data(), 3000);

  EXPECT_NE(decodeError(""), "") << "empty";
  EXPECT_NE(decodeError(block.substr(0, 3)), "") << "a frame's first bytes";
  EXPECT_NE(decodeError(block.substr(0, block.size() / 2)).find("not a whole zstd frame"), std::string::npos);
  EXPECT_NE(decodeError(block.substr(0, block.size() - 1)), "") << "the checksum cut";
  EXPECT_NE(decodeError(block + "x").find("1 bytes after the zstd frame's end"), std::string::npos);
  EXPECT_NE(decodeError(block + block), "") << "two frames";
  EXPECT_NE(decodeError(std::string(block.size(), 'z')), "") << "not zstd at all";
  std::string corrupt = block;
  corrupt[corrupt.size() / 2] = char(corrupt[corrupt.size() / 2] ^ 0x5a);
  EXPECT_NE(decodeError(corrupt), "") << "a byte changed mid-frame (the content checksum catches what zstd does not)";

  // Any single byte changed anywhere: an error or the original bits, never a crash or other bits.
  int refused = 0;
  for (size_t k = 0; k < block.size(); ++k) {
    std::string flipped = block;
    flipped[k] = char(flipped[k] ^ 0xff);
    std::vector<double> out(kSumsBlockDoubles);
    try {
      const size_t n = decodeSumsBlock(flipped, out.data(), out.size(), "flipped");
      EXPECT_TRUE(n == 3000 && std::memcmp(out.data(), sums.data(), n * sizeof(double)) == 0) << "byte " << k;
    } catch (const FarmError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, int(block.size()) * 9 / 10);
}

TEST(SumsCodec, BlocksLargerThanAllowedAreRefusedBeforeDecompressing) {
  const std::vector<double> zeros(100, 0.0);
  const std::string block = encodeSumsBlock(zeros.data(), zeros.size());
  EXPECT_EQ(decodeError(block, 100), "");
  EXPECT_NE(decodeError(block, 99).find("declares 100 doubles; at most 99 fit here"), std::string::npos)
      << "more than the unit has left";

  // A bomb: 256 MiB of zeros squeezed into a few KiB, declared in its header. Refused from the
  // header alone, however much room the caller has.
  ZSTD_CCtx* c = ZSTD_createCCtx();
  ZSTD_CCtx_setPledgedSrcSize(c, uint64_t(1) << 28);
  std::string bomb(1 << 16, '\0');
  const std::string zeroChunk(1 << 20, '\0');
  ZSTD_outBuffer out{bomb.data(), bomb.size(), 0};
  for (int i = 0; i < 256; ++i) {
    ZSTD_inBuffer in{zeroChunk.data(), zeroChunk.size(), 0};
    while (in.pos < in.size) ASSERT_FALSE(ZSTD_isError(ZSTD_compressStream2(c, &out, &in, ZSTD_e_continue)));
  }
  ZSTD_inBuffer none{nullptr, 0, 0};
  for (size_t left = 1; left != 0;) {
    left = ZSTD_compressStream2(c, &out, &none, ZSTD_e_end);
    ASSERT_FALSE(ZSTD_isError(left));
  }
  ZSTD_freeCCtx(c);
  bomb.resize(out.pos);
  ASSERT_EQ(ZSTD_getFrameContentSize(bomb.data(), bomb.size()), uint64_t(1) << 28);
  EXPECT_LT(bomb.size(), size_t(1) << 16);
  EXPECT_NE(decodeError(bomb, size_t(1) << 40).find("declares 33554432 doubles; at most 65536 fit here"),
            std::string::npos);

  // A frame that does not say its size, and one of a size that is not whole doubles.
  c = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(c, ZSTD_c_contentSizeFlag, 0);
  std::string unsized(ZSTD_compressBound(800), '\0');
  unsized.resize(ZSTD_compress2(c, unsized.data(), unsized.size(), zeros.data(), 800));
  ZSTD_freeCCtx(c);
  EXPECT_NE(decodeError(unsized).find("does not declare its content size"), std::string::npos);
  std::string odd(ZSTD_compressBound(7), '\0');
  odd.resize(ZSTD_compress(odd.data(), odd.size(), zeros.data(), 7, 1));
  EXPECT_NE(decodeError(odd).find("declares 7 bytes, not whole doubles"), std::string::npos);
}

}  // namespace
}  // namespace lensfarm
