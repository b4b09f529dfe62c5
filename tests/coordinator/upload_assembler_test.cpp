// Reassembling uploads: every malformed stream is refused before it can touch a sensor.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "upload_assembler.h"

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
