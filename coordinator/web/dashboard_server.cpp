#include "coordinator/web/dashboard_server.h"

#include <arpa/inet.h>
#include <spdlog/spdlog.h>
#include <strings.h>

#include <nlohmann/json.hpp>

#include <charconv>

#include "common/util/error.h"
#include "common/util/log_text.h"
#include "coordinator/web/dashboard_assets.h"

namespace lensfarm {

namespace {

constexpr const char* kJson = "application/json";

void fail(HttpResponse& response, int status, const std::string& message) {
  response.status = status;
  response.setContent(nlohmann::json{{"error", message}}.dump(), kJson);
}

std::optional<double> evOf(const HttpRequest& request) {
  if (!request.hasParam("ev")) return std::nullopt;
  try {
    const double ev = std::stod(request.param("ev"));
    if (!std::isfinite(ev) || ev < -20 || ev > 20) throw std::out_of_range("ev");
    return ev;
  } catch (const std::exception&) {
    throw InputError("ev", "expected a number of stops in [-20, 20]");
  }
}

void setImageHeaders(HttpResponse& response, const Dashboard::Png& png) {
  response.setHeader("Cache-Control", "no-store");
  response.setHeader("X-Samples-Per-Pixel", std::to_string(png.samplesPerPixel));
  response.setHeader("X-Job-Version", std::to_string(png.version));
  response.setHeader("X-Ev", std::to_string(png.ev));
  response.setHeader("X-Width", std::to_string(png.width));
  response.setHeader("X-Height", std::to_string(png.height));
}

}  // namespace

bool loopbackHost(std::string_view host) {
  std::string_view name = host, port;
  if (!host.empty() && host.front() == '[') {
    const size_t close = host.find(']');
    if (close == std::string_view::npos) return false;
    name = host.substr(0, close + 1);
    port = host.substr(close + 1);
  } else if (const size_t colon = host.find(':'); colon != std::string_view::npos) {
    name = host.substr(0, colon);
    port = host.substr(colon);
  }
  if (!port.empty()) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data() + 1, port.data() + port.size(), value);
    if (port.front() != ':' || port.size() < 2 || port.size() > 6 || ec != std::errc() ||
        end != port.data() + port.size() || value > 65535)
      return false;
  }
  if ((name.size() == 9 && ::strncasecmp(name.data(), "localhost", 9) == 0) || name == "[::1]") return true;
  in_addr address{};
  const std::string text(name);
  return inet_pton(AF_INET, text.c_str(), &address) == 1 && (ntohl(address.s_addr) >> 24) == 127;
}

namespace {

// The /api guard, run on the header before the body is read: the Host, the Content-Type of an
// action, then the token. GET routes need the viewer or the client token, POST routes (the
// actions) the client token. Browsers guard the rest: a POST must be JSON (another site's page
// cannot send that without a CORS preflight, which this server never grants), and a coordinator
// without a token answers only requests addressed to this machine by a loopback name or address
// (no DNS rebinding onto a loopback dashboard).
HttpGuard apiGuard(Dashboard& dashboard, ThrottledLog& refusals) {
  return [&dashboard, &refusals](const HttpRequest& request, HttpResponse& response) {
    const std::string host = request.header("Host");
    if (!dashboard.tokenRequired() && !loopbackHost(host)) {
      fail(response, 403, "without a client token the dashboard answers only requests to localhost");
      return true;
    }
    const bool action = request.method == "POST";
    if (action && request.header("Content-Type").rfind("application/json", 0) != 0) {
      fail(response, 415, "POST a JSON body (Content-Type: application/json)");
      return true;
    }
    const std::string header = request.header("Authorization");
    const Dashboard::Access access = dashboard.access(header);
    const char* tokens = dashboard.viewerToken() ? "client or viewer token" : "client token";
    if (access == Dashboard::Access::kNone) {
      const char* why = header.empty() ? "missing" : "wrong";
      refusals.warn("dashboard-token", fmt::format("dashboard: refused {} {} from {}: {} {}", request.method,
                                                   logText(request.path), request.remoteAddress, why, tokens));
      response.setHeader("WWW-Authenticate", "Bearer");
      fail(response, 401, std::string(why) + " " + tokens);
      return true;
    }
    if (action && access != Dashboard::Access::kFull) {
      refusals.warn("dashboard-read-only",
                    fmt::format("dashboard: refused {} {} from {}: the viewer token is read-only", request.method,
                                logText(request.path), request.remoteAddress));
      fail(response, 403,
           dashboard.userOf(header) ? "a person's actions go through /api/v1 (docs/api.md), which checks their role"
                                    : "the viewer token is read-only: this needs the client token");
      return true;
    }
    return false;
  };
}

// An /api handler: the project's exceptions as HTTP statuses, and X-Lensfarm-Access telling the
// page whether to offer the actions.
template <class Body>
HttpHandler api(Dashboard& dashboard, Body body) {
  return [&dashboard, body](const HttpRequest& request, HttpResponse& response) {
    // What the page offers: "full" (every action), "own" (a submitter: actions on their own jobs,
    // through /api/v1, which checks), "read"; and who is signed in.
    const std::string authorization = request.header("Authorization");
    if (const std::optional<User> user = dashboard.userOf(authorization)) {
      response.setHeader("X-Lensfarm-Access", user->role == User::Role::kAdmin       ? "full"
                                              : user->role == User::Role::kSubmitter ? "own"
                                                                                     : "read");
      response.setHeader("X-Lensfarm-User", user->name);
    } else {
      response.setHeader("X-Lensfarm-Access",
                         dashboard.access(authorization) == Dashboard::Access::kFull ? "full" : "read");
    }
    try {
      response.setHeader("Cache-Control", "no-store");
      body(request, response);
    } catch (const InputError& e) {
      fail(response, 400, e.what());
    } catch (const FarmError& e) {
      fail(response, e.kind() == FarmError::Kind::kNotFound ? 404 : 400, e.what());
    } catch (const std::exception& e) {
      spdlog::error("dashboard: {} {}: {}", request.method, logText(request.path), logText(e.what()));
      fail(response, 500, e.what());
    }
  };
}

HttpRoutes dashboardRoutes(Dashboard& dashboard, ThrottledLog& refusals, RestApi* restApi) {
  HttpRoutes routes;
  if (restApi) restApi->addRoutes(routes);
  // The page: public, compiled into the binary.
  for (const DashboardAsset& asset : dashboardAssets()) {
    const auto serve = [asset](const HttpRequest&, HttpResponse& response) {
      response.setContent(std::string(asset.bytes), std::string(asset.contentType));
      response.setHeader("Cache-Control", "no-cache");
    };
    routes.get(std::string(asset.path), serve);
    if (asset.path == "/index.html") routes.get("/", serve);
  }
  const HttpGuard guard = apiGuard(dashboard, refusals);
  const std::string job = R"(/api/jobs/([A-Za-z0-9._-]+))";
  routes.get("/api/jobs",
             api(dashboard, [&dashboard](const HttpRequest&,
                                         HttpResponse& response) { response.setContent(dashboard.jobsJson(), kJson); }),
             guard);
  routes.get(
      "/api/workers",
      api(dashboard, [&dashboard](const HttpRequest&,
                                  HttpResponse& response) { response.setContent(dashboard.workersJson(), kJson); }),
      guard);
  routes.get(job,
             api(dashboard,
                 [&dashboard](const HttpRequest& request, HttpResponse& response) {
                   response.setContent(dashboard.jobJson(request.matches[1]), kJson);
                 }),
             guard);
  routes.get(job + "/snapshot.png",
             api(dashboard,
                 [&dashboard](const HttpRequest& request, HttpResponse& response) {
                   int maxSide = 512;
                   if (request.hasParam("max")) maxSide = std::atoi(request.param("max").c_str());
                   const Dashboard::Png png = dashboard.snapshot(request.matches[1], evOf(request), maxSide);
                   setImageHeaders(response, png);
                   response.setContent(png.bytes, "image/png");
                 }),
             guard);
  routes.get(job + "/image.png",
             api(dashboard,
                 [&dashboard](const HttpRequest& request, HttpResponse& response) {
                   const Dashboard::Png png = dashboard.png(request.matches[1], evOf(request));
                   setImageHeaders(response, png);
                   response.setHeader("Content-Disposition", "attachment; filename=\"" + request.matches[1] + ".png\"");
                   response.setContent(png.bytes, "image/png");
                 }),
             guard);
  routes.get(job + "/image.exr",
             api(dashboard,
                 [&dashboard](const HttpRequest& request, HttpResponse& response) {
                   response.setHeader("Content-Disposition", "attachment; filename=\"" + request.matches[1] + ".exr\"");
                   response.setContent(dashboard.exr(request.matches[1]), "image/x-exr");
                 }),
             guard);
  routes.post(job + "/cancel",
              api(dashboard,
                  [&dashboard](const HttpRequest& request, HttpResponse& response) {
                    response.setContent(dashboard.cancel(request.matches[1]), kJson);
                  }),
              guard);
  // The scheduling actions (docs/farm.md "Scheduling"): no body; each answers the job's summary.
  for (const auto& [name, action] :
       {std::pair<const char*, std::string (Dashboard::*)(const std::string&)>{"/pause", &Dashboard::pause},
        {"/resume", &Dashboard::resume},
        {"/approve", &Dashboard::approve}})
    routes.post(job + name,
                api(dashboard,
                    [&dashboard, call = action](const HttpRequest& request, HttpResponse& response) {
                      response.setContent((dashboard.*call)(request.matches[1]), kJson);
                    }),
                guard);
  routes.post(job + "/priority",
              api(dashboard,
                  [&dashboard](const HttpRequest& request, HttpResponse& response) {
                    const auto body = nlohmann::json::parse(request.body, nullptr, false);
                    if (body.is_discarded() || !body.is_object() || !body.contains("priority") ||
                        !body["priority"].is_number_integer())
                      throw InputError("priority", "expected a JSON body {\"priority\": INTEGER}");
                    const auto priority = body["priority"].get<int64_t>();
                    if (priority < -1000000 || priority > 1000000) throw InputError("priority", "out of range");
                    response.setContent(dashboard.setPriority(request.matches[1], int(priority)), kJson);
                  }),
              guard);
  return routes;
}

}  // namespace

DashboardServer::DashboardServer(const std::string& listen, Dashboard& dashboard, RestApi* restApi,
                                 const std::optional<HttpTls>& tls)
    : server_(listen, "--dashboard-listen", "the dashboard", dashboardRoutes(dashboard, refusals_, restApi),
              HttpLimits{}, tls) {}

}  // namespace lensfarm
