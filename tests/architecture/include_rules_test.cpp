// The house rules, checked on the sources (docs/architecture.md): every include names its path
// from the repository root; common/'s folders include only the layers below them; common/ knows
// nothing of the network or of the services; coordinator/ and worker/ never include each other;
// coordinator/'s folders include only the folders below them (store < core < rpc < web).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>

#include "tests/test_support.h"

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

// The layers of common/, lowest first (common/CMakeLists.txt builds each into its own library):
// a folder includes only folders before it. Folders on one rung may not include each other.
const std::vector<std::vector<std::string>> kLayers = {
    {"math"},  {"util"},  {"texture"},       {"camera", "medium"}, {"film", "material"},
    {"light"}, {"scene"}, {"render", "farm"}};

int rungOf(const std::string& folder) {
  for (size_t i = 0; i < kLayers.size(); ++i)
    for (const std::string& f : kLayers[i])
      if (f == folder) return int(i);
  return -1;
}

// "common/render/integrator.h" -> "render"; "" for anything outside common/.
std::string commonFolderOf(const std::string& path) {
  const std::string prefix = "common/";
  if (path.rfind(prefix, 0) != 0) return "";
  const size_t slash = path.find('/', prefix.size());
  return slash == std::string::npos ? "" : path.substr(prefix.size(), slash - prefix.size());
}

// The quoted includes of every source in the tree, each rooted at the repository.
TEST(IncludeRules, EveryIncludeNamesItsPathFromTheRoot) {
  size_t count = 0;
  for (const char* root : {"common", "coordinator", "worker", "client", "proto", "tests", "bench"}) {
    for (const auto& [file, header] : includesIn(root)) {
      if (fs::exists(test::sourceDir() / header)) {
        ++count;
      } else if (fs::exists(fs::path(file).parent_path() / header)) {
        ADD_FAILURE() << file << " includes \"" << header << "\" by its path from its own folder, not from the root";
      }  // else a library's header, or a generated one (lensfarm/v1/*.pb.h)
    }
  }
  EXPECT_GT(count, 1000u) << "the scan found the project's includes";
}

TEST(IncludeRules, CommonIncludesOnlyTheLayersBelow) {
  for (const auto& layer : kLayers) {
    for (const std::string& folder : layer) {
      ASSERT_TRUE(fs::is_directory(test::sourceDir() / "common" / folder)) << folder;
    }
  }
  for (const auto& entry : fs::directory_iterator(test::sourceDir() / "common")) {
    if (!entry.is_directory()) continue;
    EXPECT_GE(rungOf(entry.path().filename().string()), 0) << entry.path() << " has no layer";
  }
  size_t checked = 0;
  for (const auto& [file, header] : includesIn("common")) {
    const std::string from = commonFolderOf(fs::relative(file, test::sourceDir()).generic_string());
    const std::string to = commonFolderOf(header);
    if (to.empty() || to == from) continue;
    ++checked;
    EXPECT_LT(rungOf(to), rungOf(from)) << file << " includes " << header << ": common/" << from
                                        << " may include only the layers below it (math < util < texture < camera, "
                                           "medium < film, material < light < scene < render, farm)";
  }
  EXPECT_GT(checked, 100u);
}

TEST(IncludeRules, CommonHasNoNetworkAndNoServiceCode) {
  const auto includes = includesIn("common");
  ASSERT_GT(includes.size(), 50u) << "the scan found the sources";
  for (const auto& [file, header] : includes) {
    EXPECT_EQ(header.find("grpc"), std::string::npos) << file << " includes " << header;
    EXPECT_EQ(header.find(".pb.h"), std::string::npos) << file << " includes " << header;
    EXPECT_EQ(header.find("google/protobuf"), std::string::npos) << file << " includes " << header;
    for (const char* service : {"coordinator/", "worker/", "client/", "proto/"})
      EXPECT_NE(header.rfind(service, 0), 0u) << file << " includes " << header;
  }
}

TEST(IncludeRules, CoordinatorAndWorkerMeetOnlyInProtoAndCommon) {
  size_t checked = 0;
  for (const auto& [file, header] : includesIn("coordinator")) {
    EXPECT_NE(header.rfind("worker/", 0), 0u) << file << " includes the worker's " << header;
    ++checked;
  }
  for (const auto& [file, header] : includesIn("worker")) {
    EXPECT_NE(header.rfind("coordinator/", 0), 0u) << file << " includes the coordinator's " << header;
    ++checked;
  }
  EXPECT_GT(checked, 50u);
}

// The coordinator knows scenes, films and the farm's vocabulary, never the tracer: it links no
// Embree and no integrator (common/CMakeLists.txt: farm sits beside render, not above it).
TEST(IncludeRules, TheCoordinatorAndTheProtocolIncludeNoTracer) {
  size_t checked = 0;
  for (const char* root : {"coordinator", "proto", "common/farm"})
    for (const auto& [file, header] : includesIn(root)) {
      EXPECT_NE(header.rfind("common/render/", 0), 0u) << file << " includes the tracer's " << header;
      ++checked;
    }
  EXPECT_GT(checked, 100u);
}

// The folders of coordinator/, lowest first (coordinator/CMakeLists.txt builds each into its own
// library): store/ (durable state) < core/ (Coordinator) < rpc/ (gRPC services) < web/ (dashboard,
// HTTP servers, and the HTTP API, which transcodes the gRPC services); main.cpp uses all.
TEST(IncludeRules, CoordinatorFoldersIncludeOnlyTheFoldersBelow) {
  const std::map<std::string, int> rung{{"store", 0}, {"core", 1}, {"rpc", 2}, {"web", 3}};
  // "coordinator/core/coordinator.h" -> "core"; "" for anything else (coordinator/main.cpp too).
  const auto folderOf = [](const std::string& path) -> std::string {
    const std::string prefix = "coordinator/";
    if (path.rfind(prefix, 0) != 0) return "";
    const size_t slash = path.find('/', prefix.size());
    return slash == std::string::npos ? "" : path.substr(prefix.size(), slash - prefix.size());
  };
  for (const auto& entry : fs::directory_iterator(test::sourceDir() / "coordinator")) {
    if (!entry.is_directory()) continue;
    EXPECT_TRUE(rung.count(entry.path().filename().string())) << entry.path() << " has no rung";
  }
  size_t checked = 0;
  for (const auto& [file, header] : includesIn("coordinator")) {
    const std::string from = folderOf(fs::relative(file, test::sourceDir()).generic_string());
    const std::string to = folderOf(header);
    if (from.empty() || to.empty() || to == from) continue;
    ++checked;
    ASSERT_TRUE(rung.count(to)) << file << " includes " << header << ", in no folder of coordinator/";
    EXPECT_LT(rung.at(to), rung.at(from)) << file << " includes " << header << ": coordinator/" << from
                                          << " may include only the folders below it (store < core < rpc < web)";
  }
  EXPECT_GT(checked, 10u);
}

}  // namespace
}  // namespace lensfarm
