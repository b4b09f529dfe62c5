// The dashboard's port is wherever the coordinator's gRPC port is: every deploy file that serves,
// publishes or exposes the coordinator (not the workers' files, which only dial it) and
// docs/deploy.md name the port of the Compose file's --dashboard-listen next to its gRPC port.
// The structural checks (Compose ports, EXPOSE, container and Service ports, the systemd settings)
// are in container_test.cpp, kubernetes_test.cpp and systemd_test.cpp; this one catches a file
// they do not parse.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

TEST(DeployFiles, EveryFileWithTheGrpcPortHasTheDashboardPort) {
  const YAML::Node compose = YAML::LoadFile((test::sourceDir() / "deploy/docker/docker-compose.yml").string());
  std::vector<std::string> command;
  for (const auto& word : compose["services"]["coordinator"]["command"]) command.push_back(word.as<std::string>());
  const std::string grpcPort = std::to_string(test::portOf(test::optionOf(command, "--listen")));
  const std::string dashboardPort = std::to_string(test::portOf(test::optionOf(command, "--dashboard-listen")));
  ASSERT_NE(dashboardPort, "-1") << "the Compose file serves no dashboard";

  std::vector<fs::path> files = {test::sourceDir() / "docs/deploy.md"};
  for (const auto& entry : fs::recursive_directory_iterator(test::sourceDir() / "deploy"))
    if (entry.is_regular_file() && entry.path().filename().string().find("worker") == std::string::npos)
      files.push_back(entry.path());
  int checked = 0;
  for (const fs::path& file : files) {
    const std::string text = test::readFile(file);
    if (text.find(grpcPort) == std::string::npos) continue;
    ++checked;
    EXPECT_NE(text.find(dashboardPort), std::string::npos)
        << file << " names the gRPC port " << grpcPort << " but not the dashboard port " << dashboardPort;
  }
  EXPECT_GE(checked, 6) << "compose, Dockerfile, the StatefulSet, the Services, coordinator.env, deploy.md";
}

}  // namespace
}  // namespace lensfarm
