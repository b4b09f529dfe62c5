#include "coordinator/web/metrics_server.h"

#include "coordinator/core/metrics.h"

namespace lensfarm {

namespace {

HttpRoutes metricsRoutes(std::function<std::string()> render) {
  HttpRoutes routes;
  routes.get("/metrics", [render = std::move(render)](const HttpRequest&, HttpResponse& response) {
    response.setContent(render(), kMetricsContentType);
  });
  return routes;
}

// A scrape is a bodiless GET: no body is accepted, and a couple of handler threads suffice.
HttpLimits metricsLimits() {
  HttpLimits limits;
  limits.maxBodyBytes = 0;
  limits.handlerThreads = 2;
  return limits;
}

}  // namespace

MetricsServer::MetricsServer(const std::string& listen, std::function<std::string()> render)
    : server_(listen, "--metrics-listen", "metrics", metricsRoutes(std::move(render)), metricsLimits()) {}

}  // namespace lensfarm
