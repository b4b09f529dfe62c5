#include "common/util/service_flags.h"

#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <filesystem>

#include <CLI/CLI.hpp>
#include <iostream>

namespace lensfarm {

void addLogLevelOption(CLI::App& app, std::string& level) {
  app.add_option("--log-level", level, "trace, debug, info, warn, error")
      ->envname("LENSFARM_LOG_LEVEL")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
}

std::optional<int> parseServiceFlags(CLI::App& app, int argc, char** argv, const std::string& program) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 2;
  }
  return std::nullopt;
}

void createFilesPrivately() { ::umask(077); }

void makePrivateDirectory(const std::string& dir, const char* flag) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!ec) std::filesystem::permissions(dir, std::filesystem::perms::owner_all, ec);
  if (ec) spdlog::warn("{} {}: cannot make it private to its owner (mode 0700): {}", flag, dir, ec.message());
}

}  // namespace lensfarm
