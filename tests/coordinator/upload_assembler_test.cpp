// Reassembling uploads: every malformed stream is refused before it can touch a sensor.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace lensfarm
