#pragma once
// The coordinator's metrics in the Prometheus text exposition format (version 0.0.4), rendered
// from a MetricsSnapshot (coordinator.h). No network code: metrics_server.h serves the text over
// HTTP. Every metric is named lensfarm_*, has HELP and TYPE lines, and counters end in _total;
// docs/deploy.md lists them with their meanings.
#include <string>

#include "coordinator/core/coordinator.h"

namespace lensfarm {

inline constexpr const char* kMetricsContentType = "text/plain; version=0.0.4; charset=utf-8";

std::string renderMetrics(const MetricsSnapshot& snapshot);

}  // namespace lensfarm
