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
  // Expiry: a date (00:00 UTC) or a UTC time; anything else names the line.
  const std::vector<User> dated = parseUsers(
      "ann submitter " + kAnn + " expires=2027-03-31\nbob viewer " + sha256Hex("b") + " expires=2027-03-31T18:30:00Z\n",
      "users");
  EXPECT_EQ(dated[0].expiresUnixSeconds, std::optional<int64_t>(1806451200));  // date -u -d 2027-03-31 +%s
  EXPECT_EQ(dated[0].expiryText(), "2027-03-31T00:00:00Z");
  EXPECT_EQ(dated[1].expiresUnixSeconds, std::optional<int64_t>(1806451200 + 18 * 3600 + 30 * 60));
  EXPECT_TRUE(dated[0].expired(1806451200));
  EXPECT_FALSE(dated[0].expired(1806451199));
  EXPECT_FALSE(users[0].expired(INT64_MAX)) << "no date: never";
  for (const std::string bad :
       {"expires=2027-02-30", "expires=31.03.2027", "until=2027-03-31", "expires=2027-03-31T18:30:00", "expires="})
    EXPECT_NE(
        refusal("ann submitter " + kAnn + " " + bad).find("users:1: \"" + bad + "\": expected expires=YYYY-MM-DD"),
        std::string::npos)
        << bad << ": " << refusal("ann submitter " + kAnn + " " + bad);
  EXPECT_NE(refusal("ann submitter " + kAnn + " expires=2027-03-31 more").find("users:1: expected"), std::string::npos);
  // Known by a client certificate's name instead of a token.
  const std::vector<User> certified =
      parseUsers("ann submitter cert=ann@studio expires=2027-03-31\nbob viewer " + kAnn + "\n", "users");
  EXPECT_EQ(certified[0].certificateName, "ann@studio");
  EXPECT_TRUE(certified[0].tokenSha256.empty());
  EXPECT_EQ(userOfCertificate(certified, "ann@studio")->name, "ann");
  EXPECT_FALSE(userOfCertificate(certified, "ann"));
  EXPECT_FALSE(userOfCertificate(certified, "")) << "bob has no certificate name";
  EXPECT_EQ(userOfToken(certified, "anns-very-own-token-2")->name, "bob");
  EXPECT_NE(refusal("ann submitter cert=").find("users:1: cert=NAME"), std::string::npos);
  EXPECT_NE(refusal("ann submitter cert=a/b").find("users:1: cert=NAME"), std::string::npos);
  EXPECT_NE(refusal("ann submitter cert=x\nbob viewer cert=x").find("users:2: the certificate x is another user's"),
            std::string::npos);
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
