// Reassembling uploads: every malformed stream is refused before it can touch a sensor.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <string>

#include "common/farm/sums_codec.h"
#include "coordinator/rpc/upload_assembler.h"

namespace lensfarm {
namespace {

v1::UploadResultRequest header(uint32_t w, uint32_t h) {
  v1::UploadResultRequest r;
  r.mutable_header()->set_width(w);
  r.mutable_header()->set_height(h);
  r.mutable_header()->set_job_id("job-1");
  r.mutable_header()->set_unit_index(3);
  return r;
}

v1::UploadResultRequest& sums(v1::UploadResultRequest& r, uint64_t offset, const std::vector<double>& values) {
  r.set_offset(offset);
  r.set_sums(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  return r;
}

TEST(UploadAssembler, ReassemblesPiecesInOrder) {
  UploadAssembler a;
  auto first = header(2, 1);
  a.add(sums(first, 0, {1, 2, 3, 4}));
  v1::UploadResultRequest second;
  a.add(sums(second, 4, {5, 6}));
  const UnitResult r = a.finish();
  EXPECT_EQ(r.jobId, "job-1");
  EXPECT_EQ(r.unitIndex, 3u);
  EXPECT_EQ(r.buffer.sums, (std::vector<double>{1, 2, 3, 4, 5, 6}));
}

TEST(UploadAssembler, RefusesEveryMalformedStream) {
  const auto refuses = [](const std::function<void(UploadAssembler&)>& stream) {
    UploadAssembler a;
    try {
      stream(a);
      a.finish();
    } catch (const FarmError& e) {
      return e.kind() == FarmError::Kind::kInvalidArgument;
    }
    return false;
  };
  EXPECT_TRUE(refuses([](UploadAssembler&) {})) << "empty";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    v1::UploadResultRequest r;
    a.add(sums(r, 0, {1}));
  })) << "no header";
  EXPECT_TRUE(refuses([](UploadAssembler& a) { a.add(header(0, 5)); })) << "zero width";
  EXPECT_TRUE(refuses([](UploadAssembler& a) { a.add(header(100000, 100000)); })) << "huge frame";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    a.add(header(2, 1));
    a.add(header(2, 1));
  })) << "two headers";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    auto h = header(2, 1);
    a.add(sums(h, 2, {1, 2}));
  })) << "out of order";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    auto h = header(1, 1);
    a.add(sums(h, 0, {1, 2, 3, 4}));
  })) << "too long";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    auto h = header(1, 1);
    h.set_sums("12345");
    a.add(h);
  })) << "not whole doubles";
  EXPECT_TRUE(refuses([](UploadAssembler& a) {
    auto h = header(2, 1);
    a.add(sums(h, 0, {1, 2, 3}));
  })) << "truncated";
}

// ---- compressed sums (SUMS_ENCODING_SHUFFLE_ZSTD) ---------------------------------------------

// A w x h unit's sums, 3 per cell, values with every kind of bits in them.
std::vector<double> unitSums(uint32_t w, uint32_t h) {
  std::vector<double> v(size_t(w) * h * 3);
  for (size_t k = 0; k < v.size(); ++k) v[k] = k % 7 == 0 ? -0.0 : double(k) * 0.37 + 1e-310;
  return v;
}

// The messages a worker sends for `v` in blocks of `block` doubles (the first with the header).
std::vector<v1::UploadResultRequest> compressedUpload(uint32_t w, uint32_t h, const std::vector<double>& v,
                                                      size_t block = kSumsBlockDoubles) {
  std::vector<v1::UploadResultRequest> pieces;
  for (size_t offset = 0; offset < v.size(); offset += block) {
    v1::UploadResultRequest r = offset == 0 ? header(w, h) : v1::UploadResultRequest();
    if (offset == 0) r.mutable_header()->set_encoding(v1::SUMS_ENCODING_SHUFFLE_ZSTD);
    r.set_offset(offset);
    r.set_sums(encodeSumsBlock(v.data() + offset, std::min(block, v.size() - offset)));
    pieces.push_back(std::move(r));
  }
  return pieces;
}

TEST(UploadAssembler, DecodesCompressedBlocksIntoTheUnitAtTheirOffsets) {
  // 200 x 150 cells: 90000 doubles, two blocks (65536 + 24464), as a lensfarm worker cuts them.
  const std::vector<double> v = unitSums(200, 150);
  for (size_t block : {kSumsBlockDoubles, size_t(1000), size_t(7)}) {  // any block size up to the limit
    SCOPED_TRACE(block);
    UploadAssembler a;
    uint64_t wire = 0;
    for (const auto& piece : compressedUpload(200, 150, v, block)) {
      a.add(piece);
      wire += piece.sums().size();
    }
    EXPECT_EQ(a.wireBytes(), wire);
    const UnitResult r = a.finish();
    ASSERT_EQ(r.buffer.sums.size(), v.size());
    EXPECT_EQ(std::memcmp(r.buffer.sums.data(), v.data(), v.size() * sizeof(double)), 0) << "bit for bit";
  }
  // An empty `sums` carries no block (e.g. the header alone first).
  UploadAssembler a;
  auto first = header(2, 1);
  first.mutable_header()->set_encoding(v1::SUMS_ENCODING_SHUFFLE_ZSTD);
  a.add(first);
  auto pieces = compressedUpload(2, 1, unitSums(2, 1));
  pieces[0].clear_header();
  a.add(pieces[0]);
  EXPECT_EQ(a.finish().buffer.sums.size(), 6u);
}

TEST(UploadAssembler, RefusesBadCompressedPiecesNamingTheirOffset) {
  const std::vector<double> v = unitSums(100, 10);  // 3000 doubles
  const auto refusal = [&](const std::function<void(std::vector<v1::UploadResultRequest>&)>& spoil) -> std::string {
    auto pieces = compressedUpload(100, 10, v, 1000);
    spoil(pieces);
    UploadAssembler a;
    try {
      for (const auto& p : pieces) a.add(p);
      a.finish();
    } catch (const FarmError& e) {
      return e.kind() == FarmError::Kind::kInvalidArgument ? e.what() : "not INVALID_ARGUMENT";
    }
    return "accepted";
  };
  EXPECT_EQ(refusal([](auto&) {}), "accepted");
  EXPECT_NE(refusal([](auto& p) {
              p[1].set_sums(p[1].sums().substr(0, p[1].sums().size() - 5));
            }).find("UploadResult: the block at offset 1000: "),
            std::string::npos)
      << "truncated";
  EXPECT_NE(refusal([](auto& p) {
              std::string s = p[2].sums();
              s[s.size() / 2] = char(s[s.size() / 2] ^ 1);
              p[2].set_sums(s);
            }).find("the block at offset 2000: "),
            std::string::npos)
      << "corrupt";
  EXPECT_NE(refusal([&](auto& p) { p[2].set_sums(encodeSumsBlock(v.data(), 1001)); }).find("at most 1000 fit here"),
            std::string::npos)
      << "more than the unit has left";
  EXPECT_NE(refusal([](auto& p) { p.pop_back(); }).find("truncated: 2000 of 3000 sums"), std::string::npos);
  EXPECT_NE(refusal([](auto& p) { p[1].set_offset(999); }).find("out of order"), std::string::npos);
  EXPECT_NE(refusal([](auto& p) {
              // Raw bytes where a block belongs: the encoding is the header's for the whole stream.
              const std::vector<double> raw(1000, 1.0);
              p[1].set_sums(reinterpret_cast<const char*>(raw.data()), raw.size() * sizeof(double));
            }).find("not a whole zstd frame"),
            std::string::npos);
  EXPECT_NE(refusal([](auto& p) {
              p[0].mutable_header()->set_encoding(v1::SumsEncoding(7));
            }).find("unknown sums encoding 7"),
            std::string::npos);
}

// ---- assets ---------------------------------------------------------------------------------

const std::string kSha(64, 'c');  // well formed; AssetStore::put checks the bytes against it

v1::UploadAssetRequest assetChunk(const std::string& data, uint64_t totalSize = 0, const std::string& sha = "") {
  v1::UploadAssetRequest m;
  m.set_sha256(sha);
  m.mutable_chunk()->set_total_size(totalSize);
  m.mutable_chunk()->set_data(data);
  return m;
}

TEST(AssetUploadAssembler, ReassemblesChunksOfAtMostOneMebibyteToTheDeclaredSize) {
  const std::string mib(AssetUploadAssembler::kMaxChunkBytes, 'x');
  AssetUploadAssembler a;
  EXPECT_FALSE(a.started());
  a.add(assetChunk(mib, 2 * mib.size() + 3, kSha));
  EXPECT_TRUE(a.started());
  EXPECT_EQ(a.sha256(), kSha);
  a.add(assetChunk(mib));
  a.add(assetChunk("abc", 2 * mib.size() + 3));  // a later chunk repeating the size agrees with it
  EXPECT_EQ(a.finish(), mib + mib + "abc");

  AssetUploadAssembler empty;  // an empty asset: one message declaring 0 bytes
  empty.add(assetChunk("", 0, kSha));
  EXPECT_EQ(empty.finish(), "");
}

TEST(AssetUploadAssembler, RefusesEveryMalformedStreamNamingTheFault) {
  const std::string mib(AssetUploadAssembler::kMaxChunkBytes, 'x');
  const auto refusal = [](const std::function<void(AssetUploadAssembler&)>& stream) -> std::string {
    AssetUploadAssembler a;
    try {
      stream(a);
      a.finish();
    } catch (const FarmError& e) {
      return e.kind() == FarmError::Kind::kInvalidArgument ? e.what() : "not INVALID_ARGUMENT";
    }
    return "accepted";
  };
  EXPECT_EQ(refusal([](AssetUploadAssembler&) {}), "UploadAsset: the first message must name the sha256");
  EXPECT_EQ(refusal([](AssetUploadAssembler& a) { a.add(assetChunk("ab", 2)); }),
            "UploadAsset: the first message must name the sha256");
  EXPECT_EQ(refusal([](AssetUploadAssembler& a) { a.add(assetChunk("ab", 2, std::string(64, 'C'))); }),
            "UploadAsset: sha256: \"" + std::string(64, 'C') + "\" is not a SHA-256 (64 lowercase hex digits)");
  EXPECT_EQ(refusal([](AssetUploadAssembler& a) { a.add(assetChunk("ab", 2, "c0ffee")); }),
            "UploadAsset: sha256: \"c0ffee\" is not a SHA-256 (64 lowercase hex digits)");
  EXPECT_EQ(refusal([&](AssetUploadAssembler& a) {
              a.add(assetChunk(mib, 4 * mib.size(), kSha));
              a.add(assetChunk(mib + mib));
            }),
            "UploadAsset: chunk[1] is 2097152 bytes; a chunk is at most 1 MiB (1048576 bytes)");
  EXPECT_EQ(refusal([&](AssetUploadAssembler& a) {
              a.add(assetChunk(mib, mib.size() + 1, kSha));
              a.add(assetChunk("ab"));
            }),
            "UploadAsset: chunk[1] goes past the declared total_size: 1048578 bytes of 1048577");
  EXPECT_EQ(refusal([&](AssetUploadAssembler& a) { a.add(assetChunk(mib, mib.size() + 1, kSha)); }),
            "UploadAsset: the stream ended after 1048576 bytes of the declared total_size 1048577");
  EXPECT_EQ(refusal([&](AssetUploadAssembler& a) {
              a.add(assetChunk("ab", 4, kSha));
              a.add(assetChunk("cd", 5));
            }),
            "UploadAsset: chunk[1] declares total_size 5, the first 4");
  EXPECT_EQ(refusal([](AssetUploadAssembler& a) { a.add(assetChunk("", (uint64_t(2) << 30) + 1, kSha)); }),
            "UploadAsset: total_size 2147483649 bytes: an asset is at most 2 GiB (2147483648 bytes)");
}

}  // namespace
}  // namespace lensfarm
