#pragma once
// What the two services share: --log-level, one way to fail on a bad flag, and private files.
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

// Every file and directory the process creates from now on is its owner's alone (umask 077: the
// state dir's scenes, assets, images and database; the worker's cache), whatever the umask it was
// started with.
void createFilesPrivately();

// Creates `dir` if needed and makes it its owner's alone (0700), so files already inside (from an
// older run or another umask) are out of others' reach too. A directory it cannot change (a volume
// mounted by someone else) gets a warning naming `flag`, not an error.
void makePrivateDirectory(const std::string& dir, const char* flag);

}  // namespace lensfarm
