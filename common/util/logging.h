#pragma once
// One logging set-up for every binary: spdlog to stderr with time, component and level.
#include <string>

namespace lensfarm {

// `component` names the process in each line (e.g. "coordinator", "worker host-123");
// `level` is trace, debug, info, warn or error.
void setupLogging(const std::string& component, const std::string& level);

}  // namespace lensfarm
