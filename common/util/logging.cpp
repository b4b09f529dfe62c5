#include "common/util/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace lensfarm {

void setupLogging(const std::string& component, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(component);
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%n] %^%l%$ %v");
  spdlog::set_level(spdlog::level::from_str(level));
}

}  // namespace lensfarm
