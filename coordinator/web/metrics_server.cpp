#include "coordinator/web/metrics_server.h"

#include <httplib.h>

#include "coordinator/core/metrics.h"

namespace lensfarm {

MetricsServer::MetricsServer(const std::string& listen, std::function<std::string()> render)
    : server_(listen, "--metrics-listen", "metrics", 2,  // scrapes are rare and small
              [&render](httplib::Server& server) {
                server.Get("/metrics",
                           [render = std::move(render)](const httplib::Request&, httplib::Response& response) {
                             response.set_content(render(), kMetricsContentType);
                           });
              }) {}

}  // namespace lensfarm
