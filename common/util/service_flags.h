#pragma once
// What the two services' command lines share: --log-level and one way to fail on a bad flag.
#include <optional>
#include <string>

namespace CLI {
class App;
}

namespace lensfarm {

// Adds --log-level (trace, debug, info, warn, error; or LENSFARM_LOG_LEVEL) bound to `level`.
void addLogLevelOption(CLI::App& app, std::string& level);

// Parses argv into `app`: std::nullopt to go on, or the exit code to return (0 after --help,
// 2 after one line on stderr naming `program` and the bad flag).
std::optional<int> parseServiceFlags(CLI::App& app, int argc, char** argv, const std::string& program);

}  // namespace lensfarm
