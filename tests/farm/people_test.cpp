// People and permissions end to end (docs/farm.md "People and permissions"): a real coordinator
// with a users file (hashed tokens) and the real CLI, three people and the administrators' token.
// A submitter owns what they submit whatever --owner says and acts on their own jobs only; a
// viewer reads and is refused every action; a forged token is refused; every refusal names what
// is missing, exits 6 and changes nothing.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/util/hash.h"
#include "tests/farm/farm_fixture.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

constexpr int kNotAllowed = 6;  // the CLI's exit code for UNAUTHENTICATED / PERMISSION_DENIED

class PeopleFarm : public test::FarmFixture {
 protected:
  fs::path token(const std::string& name, const std::string& secret) {
    return dir_.write(name + ".token", secret + "\n");
  }
  test::ProcessResult as(const fs::path& tokenFile, std::vector<std::string> args) {
    args.insert(args.end(), {"--coordinator", address_, "--token-file", tokenFile.string()});
    return cli(args);
  }
  std::string address_;
};

TEST_F(PeopleFarm, EachPersonActsOnlyAsTheirRoleAllows) {
  const fs::path admin = token("admin", "the-administrators-token-1");
  const fs::path ann = token("ann", "anns-very-own-token-2"), bob = token("bob", "bobs-very-own-token-3"),
                 vic = token("vic", "vics-very-own-token-4"), forged = token("forged", "not-anyones-token-5");
  const fs::path users = dir_.write("users", "# name role sha256\nann submitter " + sha256Hex("anns-very-own-token-2") +
                                                 "\nbob submitter " + sha256Hex("bobs-very-own-token-3") +
                                                 "\nvic viewer " + sha256Hex("vics-very-own-token-4") + "\n");
  address_ = startCoordinator("127.0.0.1:0", {"--client-token-file", admin.string(), "--users", users.string()});
  const fs::path scene = writeScene(16, 64, 1);

  // ann's job is ann's, whatever --owner says.
  const auto submitted = as(ann, {"submit", scene.string(), "--owner", "mallory", "--paused"});
  ASSERT_EQ(submitted.exitCode, 0) << submitted.err;
  const std::string job = submitted.out.substr(0, submitted.out.find('\n'));
  EXPECT_TRUE(test::contains(as(vic, {"status", job}).out, "owner:      ann")) << "a viewer reads";

  // bob may not act on ann's job; the viewer may not act at all, nor submit; a forged token is refused.
  const auto bobCancels = as(bob, {"cancel", job});
  EXPECT_EQ(bobCancels.exitCode, kNotAllowed);
  EXPECT_TRUE(test::contains(
      bobCancels.err, "CancelJob " + job + ": bob (submitter) may act on their own jobs only; " + job + " is ann's"))
      << bobCancels.err;
  const auto vicResumes = as(vic, {"resume", job});
  EXPECT_EQ(vicResumes.exitCode, kNotAllowed);
  EXPECT_TRUE(test::contains(vicResumes.err, "ResumeJob: vic is a viewer: reading only")) << vicResumes.err;
  const auto vicSubmits = as(vic, {"submit", scene.string()});
  EXPECT_EQ(vicSubmits.exitCode, kNotAllowed);
  const auto forgedStatus = as(forged, {"status", job});
  EXPECT_EQ(forgedStatus.exitCode, kNotAllowed);
  EXPECT_TRUE(test::contains(forgedStatus.err, "wrong")) << forgedStatus.err;
  EXPECT_TRUE(test::contains(as(admin, {"status", job}).out, "paused:     yes")) << "nothing changed";

  // ann acts on her own job; the administrators' token on anyone's.
  EXPECT_EQ(as(ann, {"resume", job}).exitCode, 0);
  EXPECT_EQ(as(admin, {"pause", job}).exitCode, 0);
  EXPECT_EQ(as(admin, {"cancel", job}).exitCode, 0);
  EXPECT_TRUE(test::contains(as(ann, {"status", job}).out, "state:      cancelled"));
  // Neither the tokens nor their hashes are in the coordinator's log.
  for (const std::string& secret :
       std::vector<std::string>{"anns-very-own-token-2", "not-anyones-token-5", sha256Hex("anns-very-own-token-2")})
    EXPECT_FALSE(test::contains(coordinator_->log(), secret));
}

TEST_F(PeopleFarm, AnExpiredTokenIsRefusedEverywhereNamingWhenItExpired) {
  const fs::path admin = token("admin", "the-administrators-token-1");
  const fs::path ann = token("ann", "anns-very-own-token-2"), bob = token("bob", "bobs-very-own-token-3");
  const fs::path users = dir_.write("users", "ann submitter " + sha256Hex("anns-very-own-token-2") +
                                                 " expires=2020-01-01\nbob submitter " +
                                                 sha256Hex("bobs-very-own-token-3") + " expires=2999-12-31\n");
  fs::permissions(users, fs::perms::owner_read | fs::perms::owner_write);
  address_ = startCoordinator("127.0.0.1:0", {"--client-token-file", admin.string(), "--users", users.string()});
  const auto refused = as(ann, {"status"});
  EXPECT_EQ(refused.exitCode, kNotAllowed);
  EXPECT_TRUE(test::contains(refused.err, "the token of ann expired at 2020-01-01T00:00:00Z")) << refused.err;
  EXPECT_EQ(as(ann, {"submit", writeScene(16, 8, 8).string()}).exitCode, kNotAllowed);
  EXPECT_EQ(as(bob, {"status"}).exitCode, 0) << "a date to come: accepted";
}

TEST_F(PeopleFarm, ABadUsersFileStopsTheCoordinatorNamingTheLine) {
  const fs::path admin = token("admin", "the-administrators-token-1");
  const fs::path users = dir_.write("users", "ann submitter " + sha256Hex("anns-very-own-token-2") + "\nbob owner " +
                                                 sha256Hex("bobs-very-own-token-3") + "\n");
  const auto r = test::runProcess({test::coordinatorPath(), "--listen", "127.0.0.1:0", "--client-token-file",
                                   admin.string(), "--users", users.string()},
                                  30);
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_TRUE(test::contains(r.err, users.string() + ":2: unknown role \"owner\" (admin, submitter, viewer)")) << r.err;
  const fs::path clear = dir_.write("clear", "ann submitter anns-very-own-token-2\n");
  const auto plain = test::runProcess({test::coordinatorPath(), "--listen", "127.0.0.1:0", "--client-token-file",
                                       admin.string(), "--users", clear.string()},
                                      30);
  EXPECT_EQ(plain.exitCode, 2);
  EXPECT_TRUE(test::contains(plain.err, "never the token itself")) << plain.err;
}

}  // namespace
}  // namespace lensfarm
