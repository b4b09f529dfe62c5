#include "coordinator/web/dashboard_server.h"

#include <httplib.h>
#include <spdlog/spdlog.h>

#include <nlohmann/json.hpp>

#include "common/util/error.h"
#include "coordinator/web/dashboard_assets.h"

namespace lensfarm {

namespace {

constexpr const char* kJson = "application/json";

void fail(httplib::Response& response, int status, const std::string& message) {
  response.status = status;
  response.set_content(nlohmann::json{{"error", message}}.dump(), kJson);
}

std::optional<double> evOf(const httplib::Request& request) {
  if (!request.has_param("ev")) return std::nullopt;
  try {
    const double ev = std::stod(request.get_param_value("ev"));
    if (!std::isfinite(ev) || ev < -20 || ev > 20) throw std::out_of_range("ev");
    return ev;
  } catch (const std::exception&) {
    throw InputError("ev", "expected a number of stops in [-20, 20]");
  }
}

void setImageHeaders(httplib::Response& response, const Dashboard::Png& png) {
  response.set_header("Cache-Control", "no-store");
  response.set_header("X-Samples-Per-Pixel", std::to_string(png.samplesPerPixel));
  response.set_header("X-Job-Version", std::to_string(png.version));
  response.set_header("X-Ev", std::to_string(png.ev));
  response.set_header("X-Width", std::to_string(png.width));
  response.set_header("X-Height", std::to_string(png.height));
}

// Whether the Host header names this machine (localhost, 127.*, [::1]), with or without a port.
bool loopbackHost(const std::string& host) {
  const std::string name = host.front() == '[' ? host.substr(0, host.find(']') + 1) : host.substr(0, host.rfind(':'));
  return name == "localhost" || name.rfind("127.", 0) == 0 || name == "[::1]";
}

// Wraps an /api handler: the token first, then the project's exceptions as HTTP statuses. GET
// routes need the viewer or the client token, POST routes (the actions) the client token.
// Browsers guard the rest: a POST must be JSON (another site's page cannot send that without a
// CORS preflight, which this server never grants), and a coordinator without a token answers
// only requests addressed to this machine by name (no DNS rebinding onto a loopback dashboard).
template <class Body>
httplib::Server::Handler api(Dashboard& dashboard, Body body) {
  return [&dashboard, body](const httplib::Request& request, httplib::Response& response) {
    const std::string host = request.get_header_value("Host");
    if (!dashboard.tokenRequired() && (host.empty() || !loopbackHost(host)))
      return fail(response, 403, "without a client token the dashboard answers only requests to localhost");
    const bool action = request.method == "POST";
    if (action && request.get_header_value("Content-Type").rfind("application/json", 0) != 0)
      return fail(response, 415, "POST a JSON body (Content-Type: application/json)");
    const std::string header = request.get_header_value("Authorization");
    const Dashboard::Access access = dashboard.access(header);
    const char* tokens = dashboard.viewerToken() ? "client or viewer token" : "client token";
    if (access == Dashboard::Access::kNone) {
      const char* why = header.empty() ? "missing" : "wrong";
      spdlog::warn("dashboard: refused {} {} from {}: {} {}", request.method, request.path, request.remote_addr, why,
                   tokens);
      response.set_header("WWW-Authenticate", "Bearer");
      return fail(response, 401, std::string(why) + " " + tokens);
    }
    if (action && access != Dashboard::Access::kFull) {
      spdlog::warn("dashboard: refused {} {} from {}: the viewer token is read-only", request.method, request.path,
                   request.remote_addr);
      return fail(response, 403, "the viewer token is read-only: this needs the client token");
    }
    // Tells the page whether to offer the actions.
    response.set_header("X-Lensfarm-Access", access == Dashboard::Access::kFull ? "full" : "read");
    try {
      response.set_header("Cache-Control", "no-store");
      body(request, response);
    } catch (const InputError& e) {
      fail(response, 400, e.what());
    } catch (const FarmError& e) {
      fail(response, e.kind() == FarmError::Kind::kNotFound ? 404 : 400, e.what());
    } catch (const std::exception& e) {
      spdlog::error("dashboard: {} {}: {}", request.method, request.path, e.what());
      fail(response, 500, e.what());
    }
  };
}

}  // namespace

DashboardServer::DashboardServer(const std::string& listen, Dashboard& dashboard, const std::optional<HttpTls>& tls)
    : server_(
          listen, "--dashboard-listen", "the dashboard", 4,
          [&dashboard](httplib::Server& server) {
            // The page: public, compiled into the binary.
            for (const DashboardAsset& asset : dashboardAssets()) {
              const auto serve = [asset](const httplib::Request&, httplib::Response& response) {
                response.set_content(std::string(asset.bytes), std::string(asset.contentType).c_str());
                response.set_header("Cache-Control", "no-cache");
              };
              server.Get(std::string(asset.path), serve);
              if (asset.path == "/index.html") server.Get("/", serve);
            }
            const std::string job = R"(/api/jobs/([A-Za-z0-9._-]+))";
            server.Get("/api/jobs", api(dashboard, [&dashboard](const httplib::Request&, httplib::Response& response) {
                         response.set_content(dashboard.jobsJson(), kJson);
                       }));
            server.Get("/api/workers",
                       api(dashboard, [&dashboard](const httplib::Request&, httplib::Response& response) {
                         response.set_content(dashboard.workersJson(), kJson);
                       }));
            server.Get(job, api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                         response.set_content(dashboard.jobJson(request.matches[1]), kJson);
                       }));
            server.Get(job + "/snapshot.png",
                       api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                         int maxSide = 512;
                         if (request.has_param("max")) maxSide = std::atoi(request.get_param_value("max").c_str());
                         const Dashboard::Png png = dashboard.snapshot(request.matches[1], evOf(request), maxSide);
                         setImageHeaders(response, png);
                         response.set_content(png.bytes, "image/png");
                       }));
            server.Get(job + "/image.png",
                       api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                         const Dashboard::Png png = dashboard.png(request.matches[1], evOf(request));
                         setImageHeaders(response, png);
                         response.set_header("Content-Disposition",
                                             "attachment; filename=\"" + std::string(request.matches[1]) + ".png\"");
                         response.set_content(png.bytes, "image/png");
                       }));
            server.Get(job + "/image.exr",
                       api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                         response.set_header("Content-Disposition",
                                             "attachment; filename=\"" + std::string(request.matches[1]) + ".exr\"");
                         response.set_content(dashboard.exr(request.matches[1]), "image/x-exr");
                       }));
            server.Post(job + "/cancel",
                        api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                          response.set_content(dashboard.cancel(request.matches[1]), kJson);
                        }));
            server.Post(job + "/priority",
                        api(dashboard, [&dashboard](const httplib::Request& request, httplib::Response& response) {
                          const auto body = nlohmann::json::parse(request.body, nullptr, false);
                          if (body.is_discarded() || !body.is_object() || !body.contains("priority") ||
                              !body["priority"].is_number_integer())
                            throw InputError("priority", "expected a JSON body {\"priority\": INTEGER}");
                          const auto priority = body["priority"].get<int64_t>();
                          if (priority < -1000000 || priority > 1000000) throw InputError("priority", "out of range");
                          response.set_content(dashboard.setPriority(request.matches[1], int(priority)), kJson);
                        }));
          },
          tls) {}

}  // namespace lensfarm
