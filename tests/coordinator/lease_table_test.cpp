// LeaseTable (coordinator/core/lease_table.h): lease ids say nothing of one another (random, 53 bits,
// never 0, never one held now), and no lease outlives its longest end however often it is
// extended, nor is extended by a worker that does not hold it.
#include "coordinator/core/lease_table.h"

#include <gtest/gtest.h>

#include <set>

namespace lensfarm {
namespace {

using Clock = LeaseTable::Clock;

TEST(LeaseTable, IdsAreRandomDistinctAndFitAJsonNumber) {
  LeaseTable table;
  const auto now = Clock::now();
  std::set<uint64_t> ids;
  uint64_t previous = 0, consecutive = 0, highBits = 0;
  for (uint64_t k = 0; k < 2000; ++k) {
    const uint64_t id = table.grant("w", "job-1", k, now + std::chrono::seconds(30), now + std::chrono::hours(1));
    EXPECT_NE(id, 0u);
    EXPECT_LT(id, uint64_t(1) << 53);
    ids.insert(id);
    consecutive += id == previous + 1 ? 1 : 0;
    highBits |= id >> 40;
    previous = id;
  }
  EXPECT_EQ(ids.size(), 2000u);
  EXPECT_EQ(consecutive, 0u) << "one lease id must not tell the next";
  EXPECT_NE(highBits, 0u) << "the ids use their whole range";
}

TEST(LeaseTable, ALeaseIsExtendedOnlyByItsHolderAndNeverPastItsLongestEnd) {
  LeaseTable table;
  const auto now = Clock::now();
  const auto longest = now + std::chrono::seconds(10);
  const uint64_t id = table.grant("a", "job-1", 0, now + std::chrono::seconds(1), longest);
  EXPECT_FALSE(table.extend(id, "b", now + std::chrono::seconds(5))) << "b does not hold it";
  EXPECT_EQ(table.find(id)->deadline, now + std::chrono::seconds(1));
  EXPECT_TRUE(table.extend(id, "a", now + std::chrono::seconds(5)));
  EXPECT_EQ(table.find(id)->deadline, now + std::chrono::seconds(5));
  EXPECT_TRUE(table.extend(id, "a", now + std::chrono::hours(2)));
  EXPECT_EQ(table.find(id)->deadline, longest) << "capped at the longest end";
  EXPECT_TRUE(table.takeExpired(longest - std::chrono::milliseconds(1)).empty());
  EXPECT_EQ(table.takeExpired(longest + std::chrono::milliseconds(1)).size(), 1u);
  EXPECT_EQ(table.find(id), nullptr);
}

}  // namespace
}  // namespace lensfarm
