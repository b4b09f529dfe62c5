// People (coordinator/rpc/users.h): the users file, tokens found by their hash, and who may act
// on whose job; without a network (the same with real processes: tests/farm/people_test.cpp).
#include <gtest/gtest.h>

#include "common/farm/farm_types.h"
#include "common/util/error.h"
#include "common/util/hash.h"
#include "coordinator/rpc/users.h"

namespace lensfarm {
namespace {

const std::string kAnn = sha256Hex("anns-very-own-token-2");

TEST(Users, TheFileGivesNamesRolesAndHashesAndNamesTheLineOfAMistake) {
  const std::vector<User> users =
      parseUsers("# who\n\nann submitter " + kAnn + "\n  root admin " + sha256Hex("x") + "\n", "users");
  ASSERT_EQ(users.size(), 2u);
  EXPECT_EQ(users[0].name, "ann");
  EXPECT_EQ(users[0].role, User::Role::kSubmitter);
  EXPECT_EQ(users[1].role, User::Role::kAdmin);
  const auto refusal = [](const std::string& text) {
    try {
      parseUsers(text, "users");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refusal("ann owner " + kAnn), "users:1: unknown role \"owner\" (admin, submitter, viewer)");
  EXPECT_NE(refusal("ann submitter anns-very-own-token-2").find("never the token itself"), std::string::npos);
  EXPECT_NE(
      refusal("ann submitter " + kAnn + "\nann viewer " + sha256Hex("y")).find("users:2: user ann is given twice"),
      std::string::npos);
  EXPECT_NE(refusal("ann submitter " + kAnn + "\nbob viewer " + kAnn).find("another user's too"), std::string::npos);
  EXPECT_NE(refusal("a/b viewer " + kAnn).find("a user name is"), std::string::npos);
  EXPECT_NE(refusal("ann submitter").find("expected a name, a role"), std::string::npos);
  EXPECT_EQ(refusal("# nobody\n"), "users: holds no user (lines of: NAME ROLE SHA256)");
}

TEST(Users, ATokenFindsItsUserByItsHashOnly) {
  const std::vector<User> users = parseUsers("ann submitter " + kAnn + "\n", "users");
  ASSERT_TRUE(userOfToken(users, "anns-very-own-token-2"));
  EXPECT_EQ(userOfToken(users, "anns-very-own-token-2")->name, "ann");
  EXPECT_FALSE(userOfToken(users, kAnn)) << "the hash is not a token";
  EXPECT_FALSE(userOfToken(users, "anns-very-own-token-3"));
}

TEST(Users, SubmittersActOnTheirOwnJobsViewersOnNoneAdminsOnAll) {
  const User ann{"ann", User::Role::kSubmitter, kAnn}, vic{"vic", User::Role::kViewer, ""},
      root{"root", User::Role::kAdmin, ""};
  EXPECT_NO_THROW(checkMayAct(ann, "CancelJob", "job-1", "ann"));
  EXPECT_NO_THROW(checkMayAct(root, "CancelJob", "job-1", "ann"));
  try {
    checkMayAct(ann, "PauseJob", "job-2", "bob");
    ADD_FAILURE();
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kPermissionDenied);
    EXPECT_EQ(std::string(e.what()),
              "PauseJob job-2: ann (submitter) may act on their own jobs only; job-2 is bob's (an admin may)");
  }
  EXPECT_THROW(checkMayAct(vic, "CancelJob", "job-1", "vic"), FarmError);
}

}  // namespace
}  // namespace lensfarm
