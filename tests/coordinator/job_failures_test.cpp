// The rules of a job's failures (coordinator/core/job_failures.h), on the record alone.
#include "coordinator/core/job_failures.h"

#include <gtest/gtest.h>

namespace lensfarm {
namespace {

TEST(JobFailures, AWorkerIsBlocklistedAtItsLimitAndAUnitCountsDifferentWorkers) {
  JobFailures f;
  EXPECT_EQ(f.record(5, "w1", "w1: out of memory", 2), 1u);
  EXPECT_FALSE(f.blocks("w1"));
  EXPECT_EQ(f.record(5, "w1", "w1: out of memory", 2), 1u) << "the same worker twice is one worker";
  EXPECT_TRUE(f.blocks("w1")) << "the second failure of the job on w1 reaches the limit of 2";
  EXPECT_EQ(f.record(5, "w2", "w2: bad scene", 2), 2u);
  EXPECT_FALSE(f.blocks("w2"));
  EXPECT_EQ(f.record(6, "w2", "w2: bad scene", 2), 1u) << "unit 6's own count";
  EXPECT_TRUE(f.blocks("w2")) << "failures of different units add up per worker";
}

TEST(JobFailures, TheOldestSixteenReasonsAreKeptInOrder) {
  JobFailures f;
  for (int k = 0; k < 20; ++k) f.record(uint64_t(k), "w" + std::to_string(k), "r" + std::to_string(k), 100);
  const std::string reasons = f.reasons();
  EXPECT_EQ(reasons.rfind("r0; r1; ", 0), 0u) << reasons;
  EXPECT_NE(reasons.find("; r15"), std::string::npos) << reasons;
  EXPECT_EQ(reasons.find("r16"), std::string::npos) << reasons;
}

TEST(JobFailures, AWorkerGoneHoldingUnitsIsAnnouncedOnceWhenItComesBack) {
  JobFailures f;
  const auto now = JobFailures::Clock::now();
  f.lost("render-3", {"render-3 (worker-1.4)", "lost", "connection closed", now, {7, 8}}, true);
  ASSERT_TRUE(f.lastLoss().has_value());
  EXPECT_EQ(f.lastLoss()->units, (std::vector<uint64_t>{7, 8}));
  EXPECT_TRUE(f.rejoined("render-3"));
  EXPECT_FALSE(f.rejoined("render-3")) << "announced once";
  f.lost("render-4", {"render-4 (worker-1.5)", "left", "stopped", now, {9}}, false);
  EXPECT_EQ(f.lastLoss()->worker, "render-4 (worker-1.5)");
  EXPECT_FALSE(f.rejoined("render-4")) << "an ended job does not note the name";
}

}  // namespace
}  // namespace lensfarm
