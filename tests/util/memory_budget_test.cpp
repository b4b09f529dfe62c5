// The process-wide memory budget (common/util/memory_budget.h): what fits is granted, what does
// not is refused or waits until a reservation is returned, and the count is exact.
#include "common/util/memory_budget.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

namespace lensfarm {
namespace {

using namespace std::chrono_literals;

TEST(MemoryBudget, GrantsWhatFitsAndCountsEveryReservationOnce) {
  auto budget = MemoryBudget::create(1000);
  auto a = budget->tryReserve(600, "job-1");
  ASSERT_TRUE(a);
  EXPECT_FALSE(budget->tryReserve(401, "job-2")) << "600 + 401 > 1000";
  auto b = budget->tryReserve(400, "job-2");
  ASSERT_TRUE(b);
  EXPECT_EQ(budget->reserved(), 1000u);
  EXPECT_FALSE(budget->tryReserve(1, "job-3"));
  MemoryBudget::Reservation moved = std::move(*a);
  a.reset();  // the moved-from reservation returns nothing
  EXPECT_EQ(budget->reserved(), 1000u);
  moved.release();
  moved.release();  // once
  EXPECT_EQ(budget->reserved(), 400u);
  EXPECT_FALSE(budget->tryReserve(1001, "too big")) << "never more than the total";
  EXPECT_FALSE(budget->reserve(1001, "too big", 10s)) << "refused at once, not after the wait";
}

TEST(MemoryBudget, AWaitingReservationIsGrantedWhenAnotherIsReturned) {
  auto budget = MemoryBudget::create(100);
  auto held = budget->tryReserve(80, "job-1");
  ASSERT_TRUE(held);
  EXPECT_FALSE(budget->reserve(30, "a download", 50ms)) << "no room within the wait";
  auto waiting = std::async(std::launch::async, [&] { return budget->reserve(30, "a download", 60s).has_value(); });
  EXPECT_EQ(waiting.wait_for(100ms), std::future_status::timeout) << "it waits while there is no room";
  held->release();
  ASSERT_EQ(waiting.wait_for(30s), std::future_status::ready);
  EXPECT_TRUE(waiting.get());
  EXPECT_EQ(budget->reserved(), 0u) << "the granted reservation went back when the future dropped it";
}

TEST(MemoryBudget, ForceAdmitsPastTheTotalAndDescribeNamesTheLargest) {
  auto budget = MemoryBudget::create(1000);
  MemoryBudget::Reservation a = budget->force(700, "job-1");
  MemoryBudget::Reservation b = budget->force(500, "job-2");
  auto c = budget->force(3, "asset 0123");
  EXPECT_EQ(budget->reserved(), 1203u);
  EXPECT_FALSE(budget->tryReserve(1, "x"));
  b.rename("job-2 (renamed)");
  EXPECT_EQ(budget->describe(2),
            "holds 1.20 kB of its 1.00 kB: job-1 700 bytes, job-2 (renamed) 500 bytes, 1 more 3 bytes");
  auto unlimited = MemoryBudget::create(0);
  EXPECT_TRUE(unlimited->tryReserve(uint64_t(1) << 62, "anything"));
}

}  // namespace
}  // namespace lensfarm
