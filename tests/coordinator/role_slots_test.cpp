// Per-role caps on calls in progress (coordinator/rpc/role_slots.h): a role is refused past its
// cap, other roles are not, and a slot returned makes room.
#include "coordinator/rpc/role_slots.h"

#include <gtest/gtest.h>

#include <vector>

namespace lensfarm {
namespace {

TEST(RoleSlots, EachRoleIsCappedOnItsOwnAndSlotsComeBack) {
  RoleSlots slots(2);
  std::vector<RoleSlots::Slot> viewer;
  for (int k = 0; k < 2; ++k) {
    auto s = slots.take("viewer");
    ASSERT_TRUE(s);
    viewer.push_back(std::move(*s));
  }
  EXPECT_FALSE(slots.take("viewer")) << "a third download of one role";
  auto client = slots.take("client");
  EXPECT_TRUE(client) << "another role is not held back";
  viewer.pop_back();
  EXPECT_TRUE(slots.take("viewer")) << "a returned slot makes room (and this one goes back at once)";
  EXPECT_TRUE(slots.take("viewer"));
}

}  // namespace
}  // namespace lensfarm
