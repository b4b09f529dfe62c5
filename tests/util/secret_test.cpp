// Tokens a stranger could guess are refused, with how to make a good one; token files others can
// read are refused, with the chmod to run (common/util/secret.h).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "common/util/error.h"
#include "common/util/secret.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

std::string refusal(const std::string& token) {
  try {
    checkTokenStrength(token, "token.file");
    return "";
  } catch (const InputError& e) {
    return e.what();
  }
}

TEST(TokenStrength, RunsRepeatsAndPlaceholdersAreRefused) {
  for (const std::string bad : {"0123456789abcdef", "abcdefghijklmnopqrstuvwxyz", "ZYXWVUTSRQPONMLKJIHG",
                                "9876543210zyxwvu", "abcdef123456abcdef123456", "Tr0ub4dor&3Tr0ub4dor&3", "short-token",
                                "aaaaaaaaaaaaaaaaaaaa", "REPLACE-ME-client-token", "0011223344556677889900aabb"}) {
    const std::string why = refusal(bad);
    EXPECT_NE(why, "") << bad;
    EXPECT_NE(why.find("token.file"), std::string::npos) << why;
    EXPECT_NE(why.find("head -c 32 /dev/urandom | base64"), std::string::npos) << why;
    EXPECT_EQ(why.find(bad), std::string::npos) << "the token itself is never repeated: " << why;
  }
  EXPECT_NE(refusal("abcdef123456abcdef123456").find("repeats a pattern of 12 characters"), std::string::npos);
  EXPECT_NE(refusal("0123456789abcdef").find("mostly a run"), std::string::npos);
}

// 2,000 random tokens in the two formats the docs suggest (base64 of 32 bytes; 32 bytes in hex,
// as the Slurm script makes them) all pass: the checks do not refuse honest secrets.
TEST(TokenStrength, RandomTokensPass) {
  std::mt19937_64 rng(7);
  const std::string base64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/",
                    hex = "0123456789abcdef";
  for (int k = 0; k < 1000; ++k) {
    std::string b, h;
    for (int i = 0; i < 43; ++i) b += base64[rng() % 64];
    for (int i = 0; i < 64; ++i) h += hex[rng() % 16];
    EXPECT_EQ(refusal(b + "="), "") << b;
    EXPECT_EQ(refusal(h), "") << h;
  }
  for (const std::string good : {"client-token-for-the-dashboard-test", "Zm9vYmFyLWEtcmVhbC1yYW5kb20tdG9rZW4tMTIz"})
    EXPECT_EQ(refusal(good), "") << good;
}

TEST(TokenFile, OnlyItsOwnerMayReadIt) {
  test::TempDir dir;
  const fs::path file = dir.write("client.token", "Zm9vYmFyLWEtcmVhbC1yYW5kb20tdG9rZW4tMTIz\n");
  EXPECT_EQ(readToken(file.string(), nullptr), "Zm9vYmFyLWEtcmVhbC1yYW5kb20tdG9rZW4tMTIz");
  // Owned by someone other than root (as the test's own file is when it does not run as root),
  // no group or other permission is allowed.
  if (::geteuid() == 0) {
    ASSERT_EQ(::chown(file.c_str(), 65534, 65534), 0);
  }
  for (const auto mode : {fs::perms(0644), fs::perms(0604), fs::perms(0640), fs::perms(0620)}) {
    fs::permissions(file, mode);
    try {
      readToken(file.string(), nullptr);
      ADD_FAILURE() << "mode " << std::oct << int(mode) << " accepted";
    } catch (const InputError& e) {
      const std::string why = e.what();
      EXPECT_NE(why.find(file.string()), std::string::npos) << why;
      EXPECT_NE(why.find("chmod 600 " + file.string()), std::string::npos) << why;
    }
  }
  // Group access is allowed only when root owns the file (a mounted secret); anyone else never.
  if (::geteuid() == 0) {
    ASSERT_EQ(::chown(file.c_str(), 0, 0), 0);
    fs::permissions(file, fs::perms(0640));
    EXPECT_NO_THROW(readToken(file.string(), nullptr));
    fs::permissions(file, fs::perms(0644));
    EXPECT_THROW(readToken(file.string(), nullptr), InputError);
  }
}

}  // namespace
}  // namespace lensfarm
