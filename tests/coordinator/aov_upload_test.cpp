// A job with AOVs on the coordinator (docs/aovs.md "On the farm"): an upload must carry the job's
// sums a cell, each in the range the renderer can produce (a normal in [-n, n], a hit count in
// [0, n]); anything else is INVALID_ARGUMENT naming it, and an honest upload is summed into the
// layers. No network: the plain Coordinator class.
#include <gtest/gtest.h>

#include "coordinator/core/coordinator.h"
#include "tests/coordinator/coordinator_fixtures.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::workerInfo;

// 4 x 3, 2 samples in one unit, AOVs normal (3 sums) and depth (2): 8 sums a cell.
JobSpec normalAndDepth() {
  nlohmann::json scene = test::minimalSceneJson();
  scene["render"]["resolution"] = {4, 3};
  scene["render"]["samples_per_pixel"] = 2;
  scene["render"]["samples_per_unit"] = 2;
  JobSpec spec{"aovs.json", scene.dump(), {}, {}, std::nullopt};
  AovSet aovs;
  aovs.add(Aov::kNormal);
  aovs.add(Aov::kDepth);
  spec.overrides.aovs = aovs;
  return spec;
}

// Every cell: radiance sums 1, normal sums (0, 0, -2) (two samples of -z), depth 2 x 3 over 2 hits.
UnitResult honest(const std::string& w, const LeaseGrant& g) {
  UnitResult r = test::resultFor(w, g, 1.0);
  r.buffer = SensorBuffer(4, 3, 8);
  for (size_t c = 0; c < r.buffer.cells(); ++c) {
    double* s = &r.buffer.sums[8 * c];
    s[0] = s[1] = s[2] = 1.0;
    s[3] = 0.0, s[4] = 0.0, s[5] = -2.0;
    s[6] = 6.0, s[7] = 2.0;
  }
  return r;
}

std::string errorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(AovUpload, TheSumsACellMustBeTheJobsBeforeAnyIsRead) {
  Coordinator c;
  const std::string job = c.submit(normalAndDepth(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const LeaseGrant g = *c.lease(w, 0);
  const std::string e = errorOf([&] { c.admitUpload(w, g.leaseId, job, g.unit.index, 4, 3, 3); });
  EXPECT_NE(e.find("carries 3 sums a cell"), std::string::npos) << e;
  EXPECT_NE(e.find("normal,depth"), std::string::npos) << e;
  EXPECT_NO_THROW(c.admitUpload(w, g.leaseId, job, g.unit.index, 4, 3, 8));
  // A beauty-only buffer is the wrong size for this job.
  const std::string wrong = errorOf([&] { c.acceptResult(test::resultFor(w, g, 1.0)); });
  EXPECT_NE(wrong.find("carries 36 sums; its region holds 96 (8 a cell"), std::string::npos) << wrong;
}

TEST(AovUpload, ASumOutsideWhatTheRendererCanProduceIsRefusedNamingIt) {
  Coordinator c;
  c.submit(normalAndDepth(), 0);
  const std::string w = c.registerWorker(workerInfo("w"));
  const LeaseGrant g = *c.lease(w, 0);
  UnitResult bad = honest(w, g);
  bad.buffer.sums[8 * 5 + 5] = -3.0;  // a normal's z summed over 2 samples: at most 2 in size
  std::string e = errorOf([&] { c.acceptResult(bad); });
  EXPECT_NE(e.find("cell 5 sum 5"), std::string::npos) << e;
  bad = honest(w, g);
  bad.buffer.sums[8 * 2 + 7] = 3.0;  // 3 depth hits from 2 samples
  e = errorOf([&] { c.acceptResult(bad); });
  EXPECT_NE(e.find("cell 2 sum 7"), std::string::npos) << e;
  bad = honest(w, g);
  bad.buffer.sums[6] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf([&] { c.acceptResult(bad); }).find("non-finite"), std::string::npos);
  // Refusals harm nothing: the honest upload is then summed into the layers.
  ASSERT_TRUE(c.acceptResult(honest(w, g)));
}

TEST(AovUpload, AnHonestUploadIsDevelopedIntoTheLayers) {
  Coordinator c;
  const std::string job = c.submit(normalAndDepth(), 0).id;
  const std::string w = c.registerWorker(workerInfo("w"));
  const LeaseGrant g = *c.lease(w, 0);
  ASSERT_TRUE(c.acceptResult(honest(w, g)));
  const Image image = c.image(job).image;
  ASSERT_NE(image.layer("normal"), nullptr);
  ASSERT_NE(image.layer(""), nullptr);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      EXPECT_EQ(image.at(x, y), Spectrum(0.5f));
      EXPECT_EQ(image.layer("normal")->at(x, y, 4, 2), -1.0f);
      EXPECT_EQ(image.layer("")->at(x, y, 4, 0), 3.0f);
    }
}

TEST(AovUpload, EveryLayoutKeepsTheBeautysRangeAndEachAovGetsItsOwn) {
  // The beauty may sum to n FLT_MAX whatever AOVs follow it (a job without AOVs too).
  for (uint32_t bits = 0; bits < (1u << kAovCount); ++bits) {
    const AovLayout layout(AovSet{bits});
    for (int c = 0; c < 3; ++c) {
      double lo = 1, hi = 0;
      aovSumRange(layout, c, 8, lo, hi);
      EXPECT_EQ(lo, 0.0) << aovListText(layout.set);
      EXPECT_EQ(hi, 8.0 * double(std::numeric_limits<float>::max())) << aovListText(layout.set);
    }
  }
  AovSet all;
  for (int k = 0; k < kAovCount; ++k) all.add(Aov(k));
  const AovLayout layout(all);
  double lo = 0, hi = 0;
  aovSumRange(layout, layout.normal + 1, 8, lo, hi);
  EXPECT_LT(lo, -8.0);
  EXPECT_LT(hi, 8.01);
  aovSumRange(layout, layout.depth + 1, 8, lo, hi);
  EXPECT_EQ(hi, 8.0) << "hit counts";
  aovSumRange(layout, layout.depth, 8, lo, hi);
  EXPECT_LT(lo, 0.0) << "planar depth may be negative (a point beside a wide lens)";
}

}  // namespace
}  // namespace lensfarm
