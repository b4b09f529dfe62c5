// The per-machine worker credentials file (coordinator/rpc/worker_credentials.h): what it takes,
// and one error naming the file, line and fault for what it does not.
#include "coordinator/rpc/worker_credentials.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "common/util/error.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

const std::string kTokenA = "q7Rk2mXv9LpT4wZs8NcB1hYd";
const std::string kTokenB = "Jf3Ue6Wa0GyK5tQo2VrM8xLn";

std::string refusal(const std::string& text) {
  try {
    parseWorkerCredentials(text, "creds.txt");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(WorkerCredentials, ReadsNamesAndTokensSkippingCommentsAndBlankLines) {
  const auto c = parseWorkerCredentials("# name token\n\nrender-01  " + kTokenA + "\n\trender.02\t" + kTokenB + "  \n",
                                        "creds.txt");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].name, "render-01");
  EXPECT_EQ(c[0].token, kTokenA);
  EXPECT_EQ(c[1].name, "render.02");
  EXPECT_EQ(c[1].token, kTokenB);
}

TEST(WorkerCredentials, RefusesEachFaultNamingTheLine) {
  EXPECT_NE(refusal("a " + kTokenA + "\nb\n").find("creds.txt:2: expected a name and a token"), std::string::npos);
  EXPECT_NE(refusal("a " + kTokenA + " extra\n").find("creds.txt:1: expected"), std::string::npos);
  EXPECT_NE(refusal("bad/name " + kTokenA + "\n").find("creds.txt:1: a credential name"), std::string::npos);
  EXPECT_NE(refusal(std::string(65, 'n') + " " + kTokenA + "\n").find("creds.txt:1"), std::string::npos);
  EXPECT_NE(refusal("a 0123456789abcdef\n").find("creds.txt:1: the token is mostly a run"), std::string::npos);
  EXPECT_NE(refusal("a short\n").find("creds.txt:1: the token has 5 characters"), std::string::npos);
  EXPECT_NE(refusal("a " + kTokenA + "\na " + kTokenB + "\n").find("creds.txt:2: credential a is given twice"),
            std::string::npos);
  EXPECT_NE(refusal("a " + kTokenA + "\nb " + kTokenA + "\n").find("creds.txt:2: the token of b is also a's"),
            std::string::npos);
  EXPECT_NE(refusal("# nothing\n\n").find("creds.txt: holds no credential"), std::string::npos);
}

TEST(WorkerCredentials, RefusesAFileOthersCanRead) {
  const test::TempDir dir;
  const auto path = dir.write("creds.txt", "a " + kTokenA + "\n");
  std::filesystem::permissions(path, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write |
                                         std::filesystem::perms::others_read);
  try {
    readWorkerCredentials(path.string());
    ADD_FAILURE() << "a world-readable credentials file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos) << e.what();
  }
  std::filesystem::permissions(path, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  EXPECT_EQ(readWorkerCredentials(path.string()).size(), 1u);
}

}  // namespace
}  // namespace lensfarm
