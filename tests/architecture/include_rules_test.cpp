// The house rules of design.md, checked on the sources: common/ knows nothing of the network or
// of the services; coordinator/ and worker/ never include each other.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include "test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

// Every header a folder's sources include, with the file that includes it.
std::vector<std::pair<std::string, std::string>> includesIn(const std::string& folder) {
  std::vector<std::pair<std::string, std::string>> out;
  const std::regex include(R"(^\s*#\s*include\s*[<"]([^>"]+)[>"])");
  for (const auto& entry : fs::recursive_directory_iterator(test::sourceDir() / folder)) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".h" && ext != ".cpp") continue;
    std::ifstream in(entry.path());
    for (std::string line; std::getline(in, line);) {
      std::smatch m;
      if (std::regex_search(line, m, include)) out.emplace_back(entry.path().string(), m[1]);
    }
  }
  return out;
}

std::set<std::string> headersOf(const std::string& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(test::sourceDir() / folder))
    if (entry.path().extension() == ".h") names.insert(entry.path().filename().string());
  return names;
}

TEST(IncludeRules, CommonHasNoNetworkAndNoServiceCode) {
  const auto includes = includesIn("common");
  ASSERT_GT(includes.size(), 50u) << "the scan found the sources";
  const std::set<std::string> services = [] {
    std::set<std::string> s = headersOf("coordinator");
    for (const auto& h : headersOf("worker")) s.insert(h);
    for (const auto& h : headersOf("client")) s.insert(h);
    return s;
  }();
  for (const auto& [file, header] : includes) {
    EXPECT_EQ(header.find("grpc"), std::string::npos) << file << " includes " << header;
    EXPECT_EQ(header.find(".pb.h"), std::string::npos) << file << " includes " << header;
    EXPECT_EQ(header.find("google/protobuf"), std::string::npos) << file << " includes " << header;
    EXPECT_FALSE(services.count(fs::path(header).filename().string())) << file << " includes " << header;
  }
}

TEST(IncludeRules, CoordinatorAndWorkerMeetOnlyInProtoAndCommon) {
  const std::set<std::string> workerHeaders = headersOf("worker"), coordinatorHeaders = headersOf("coordinator");
  ASSERT_TRUE(workerHeaders.count("worker_loop.h"));
  ASSERT_TRUE(coordinatorHeaders.count("coordinator.h"));
  for (const auto& [file, header] : includesIn("coordinator"))
    EXPECT_FALSE(workerHeaders.count(header)) << file << " includes the worker's " << header;
  for (const auto& [file, header] : includesIn("worker"))
    EXPECT_FALSE(coordinatorHeaders.count(header)) << file << " includes the coordinator's " << header;
}

}  // namespace
}  // namespace lensfarm
