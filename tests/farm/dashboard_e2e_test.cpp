// The web dashboard of a real coordinator process (docs/dashboard.md): its HTTP API with and
// without the client token, the read-only viewer token, HTTPS with the coordinator's certificate
// (made by openssl at test time), and the page itself in a real browser (Debian's chromium,
// headless, driven through chromedriver's W3C WebDriver API) while a real worker renders a job:
// the image changes as samples arrive, Cancel cancels, and screenshots land in the build folder.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <optional>
#include <thread>
#include <tuple>

#include "common/film/image.h"
#include "common/film/image_io.h"
#include "common/util/hash.h"
#include "coordinator/web/dashboard.h"
#include "tests/coordinator/audit_views.h"
#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const char* kChromium = "/usr/bin/chromium";
const char* kChromedriver = "/usr/bin/chromedriver";

// How to reach a dashboard served over HTTPS: the CA to verify its certificate (and host) by, and
// for mutual TLS a client certificate and key.
struct Https {
  std::string ca, cert, key;
};

// GET or POST on the dashboard with an optional token, over HTTPS when `https` is given; the whole
// response (status 0 if none, e.g. a failed TLS handshake).
struct Reply {
  int status = 0;
  std::string body, contentType;
  httplib::Headers headers;
  httplib::Error error = httplib::Error::Success;
};
Reply request(const std::string& address, const std::string& method, const std::string& path,
              const std::string& token = "", const std::string& body = "",
              const std::optional<Https>& https = std::nullopt) {
  std::unique_ptr<httplib::Client> owned;
  if (!https) {
    owned = std::make_unique<httplib::Client>(address.substr(0, address.rfind(':')), test::portOf(address));
  } else {
    owned = https->cert.empty() ? std::make_unique<httplib::Client>("https://" + address)
                                : std::make_unique<httplib::Client>("https://" + address, https->cert, https->key);
    owned->set_ca_cert_path(https->ca);
    owned->enable_server_certificate_verification(true);
  }
  httplib::Client& client = *owned;
  client.set_connection_timeout(5);
  client.set_read_timeout(30);
  httplib::Headers headers;
  if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
  const auto response = method == "POST" ? client.Post(path.c_str(), headers, body, "application/json")
                                         : client.Get(path.c_str(), headers);
  Reply r;
  r.error = response.error();
  if (!response) return r;
  r.status = response->status;
  r.body = response->body;
  r.contentType = response->get_header_value("Content-Type");
  r.headers = response->headers;
  return r;
}

std::string decodeBase64(const std::string& text) {
  std::string out;
  uint32_t bits = 0;
  int count = 0;
  for (char c : text) {
    int v;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+')
      v = 62;
    else if (c == '/')
      v = 63;
    else
      continue;  // padding, line breaks
    bits = (bits << 6) | uint32_t(v);
    if ((count += 6) >= 8) {
      count -= 8;
      out.push_back(char((bits >> count) & 0xff));
    }
  }
  return out;
}

// A browser session through chromedriver's W3C WebDriver HTTP/JSON API.
class Browser {
 public:
  // `acceptInsecureCerts`: take a certificate the browser's own store does not trust (the test's
  // throwaway CA), as a user who accepted it once would.
  explicit Browser(const test::TempDir& dir, bool acceptInsecureCerts = false)
      : port_(test::freePort()), client_("127.0.0.1", port_) {
    driver_ = std::make_unique<test::ChildProcess>(
        std::vector<std::string>{kChromedriver, "--port=" + std::to_string(port_)}, dir / "chromedriver");
    client_.set_connection_timeout(5);
    client_.set_read_timeout(60);
    if (!test::waitFor([&] { return call("GET", "/status").value("value", json::object()).value("ready", false); }, 30))
      throw std::runtime_error("chromedriver did not start: " + driver_->log());
    const json capabilities = {{"capabilities",
                                {{"alwaysMatch",
                                  {{"acceptInsecureCerts", acceptInsecureCerts},
                                   {"goog:chromeOptions",
                                    {{"binary", kChromium},
                                     {"args",
                                      {"--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                                       "--disable-dev-shm-usage", "--window-size=1360,1100"}}}}}}}}};
    const json session = call("POST", "/session", capabilities);
    session_ = session["value"].value("sessionId", "");
    if (session_.empty()) throw std::runtime_error("no browser session: " + session.dump() + driver_->log());
  }
  ~Browser() {
    if (!session_.empty()) call("DELETE", "/session/" + session_);
  }

  json call(const std::string& method, const std::string& path, const json& body = nullptr) {
    httplib::Result r = method == "POST"
                            ? client_.Post(path.c_str(), body.is_null() ? "{}" : body.dump(), "application/json")
                        : method == "GET" ? client_.Get(path.c_str())
                                          : client_.Delete(path.c_str());
    if (!r) return json::object();
    return json::parse(r->body, nullptr, false);
  }
  json session(const std::string& method, const std::string& path, const json& body = nullptr) {
    return call(method, "/session/" + session_ + path, body);
  }
  void go(const std::string& url) { session("POST", "/url", {{"url", url}}); }
  // Runs `script` (a function body) in the page; its return value.
  json run(const std::string& script) {
    return session("POST", "/execute/sync", {{"script", script}, {"args", json::array()}})["value"];
  }
  std::string text(const std::string& css) {
    const json v = run("const e = document.querySelector(" + json(css).dump() + "); return e ? e.textContent : null;");
    return v.is_string() ? v.get<std::string>() : "";
  }
  bool visible(const std::string& css) {
    return run("const e = document.querySelector(" + json(css).dump() + "); return !!e && e.offsetParent !== null;") ==
           true;
  }
  std::string element(const std::string& css) {
    const json v = session("POST", "/element", {{"using", "css selector"}, {"value", css}})["value"];
    return v.is_object() ? v.value("element-6066-11e4-a52e-4f735466cecf", "") : "";
  }
  json type(const std::string& css, const std::string& keys) {
    return session("POST", "/element/" + element(css) + "/value", {{"text", keys}});
  }
  // Clicks like a user (WebDriver's element click: scrolled into view, hit-tested).
  json click(const std::string& css) { return session("POST", "/element/" + element(css) + "/click", json::object()); }
  void screenshot(const fs::path& file) {
    const json v = session("GET", "/screenshot")["value"];
    ASSERT_TRUE(v.is_string()) << v.dump();
    std::ofstream(file, std::ios::binary) << decodeBase64(v.get<std::string>());
  }

 private:
  int port_;
  httplib::Client client_;
  std::unique_ptr<test::ChildProcess> driver_;
  std::string session_;
};

class DashboardFarm : public ::testing::Test {
 protected:
  void SetUp() override {
    token_ = "client-token-for-the-dashboard-test";
    const fs::path tokenFile = dir_.write("client.token", token_ + "\n");
    address_ = farm_.startCoordinator({"--listen", "127.0.0.1:0", "--client-token-file", tokenFile.string(),
                                       "--dashboard-listen", "127.0.0.1:0", "--heartbeat-interval", "0.2"});
    dashboard_ = farm_.dashboardAddress();
    ASSERT_FALSE(dashboard_.empty());
  }
  std::string submit(const fs::path& scene, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {scene.string(), "--coordinator", address_, "--token-file",
                                     (dir_ / "client.token").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return farm_.submit(args);
  }
  std::string status(const std::string& job) {
    return farm_.cli({"status", job, "--coordinator", address_, "--token-file", (dir_ / "client.token").string()}).out;
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  std::string token_, address_, dashboard_;
};

TEST_F(DashboardFarm, ApiNeedsTheClientTokenAndThePageIsPublic) {
  const Reply missing = request(dashboard_, "GET", "/api/jobs");
  EXPECT_EQ(missing.status, 401);
  EXPECT_NE(missing.body.find("missing client token"), std::string::npos) << missing.body;
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs", "not-the-token").status, 401);
  EXPECT_EQ(request(dashboard_, "GET", "/api/workers", "not-the-token").status, 401);
  EXPECT_EQ(request(dashboard_, "POST", "/api/jobs/job-1/cancel", "not-the-token").status, 401);
  EXPECT_NE(farm_.coordinator().log().find("dashboard: refused GET /api/jobs from"), std::string::npos);
  EXPECT_EQ(farm_.coordinator().log().find(token_), std::string::npos) << "the token is never logged";

  const Reply jobs = request(dashboard_, "GET", "/api/jobs", token_);
  EXPECT_EQ(jobs.status, 200);
  EXPECT_EQ(jobs.contentType, "application/json");
  EXPECT_EQ(json::parse(jobs.body), json({{"jobs", json::array()}}));
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs/job-9", token_).status, 404);

  for (const auto& [path, type] : std::vector<std::pair<std::string, std::string>>{{"/", "text/html"},
                                                                                   {"/index.html", "text/html"},
                                                                                   {"/app.js", "text/javascript"},
                                                                                   {"/style.css", "text/css"}}) {
    const Reply page = request(dashboard_, "GET", path);
    EXPECT_EQ(page.status, 200) << path;
    EXPECT_EQ(page.contentType.rfind(type, 0), 0u) << path << ": " << page.contentType;
  }
  EXPECT_EQ(test::readFile(test::sourceDir() / "coordinator/web/dashboard/index.html"),
            request(dashboard_, "GET", "/").body)
      << "the page is compiled in as it is";
}

TEST_F(DashboardFarm, ApiServesJobsImagesAndActions) {
  // The first job is far too long to end during the test (it is cancelled at the end).
  const std::string first = submit(test::writeSeedScene(dir_, 48, 1 << 20, 8));
  const std::string second = submit(test::writeSeedScene(dir_, 48, 64, 8));
  const json jobs = json::parse(request(dashboard_, "GET", "/api/jobs", token_).body)["jobs"];
  ASSERT_EQ(jobs.size(), 2u);
  EXPECT_EQ(jobs[0]["id"], first);

  // Priority: the second job moves to the front.
  const Reply raised = request(dashboard_, "POST", "/api/jobs/" + second + "/priority", token_, R"({"priority": 4})");
  EXPECT_EQ(raised.status, 200) << raised.body;
  EXPECT_EQ(json::parse(raised.body)["priority"], 4);
  EXPECT_EQ(json::parse(request(dashboard_, "GET", "/api/jobs", token_).body)["jobs"][0]["id"], second);
  EXPECT_EQ(request(dashboard_, "POST", "/api/jobs/" + second + "/priority", token_, R"({"priority": "high"})").status,
            400);
  EXPECT_NE(status(second).find("priority:   4"), std::string::npos) << status(second);

  // Pause and resume (docs/farm.md "Scheduling"): the CLI sees what the dashboard did.
  const Reply paused = request(dashboard_, "POST", "/api/jobs/" + second + "/pause", token_);
  EXPECT_EQ(paused.status, 200) << paused.body;
  EXPECT_EQ(json::parse(paused.body)["paused"], true);
  EXPECT_NE(status(second).find("paused:     yes"), std::string::npos) << status(second);
  EXPECT_EQ(json::parse(request(dashboard_, "POST", "/api/jobs/" + second + "/resume", token_).body)["paused"], false);
  EXPECT_EQ(request(dashboard_, "POST", "/api/jobs/job-404/pause", token_).status, 404);
  EXPECT_EQ(request(dashboard_, "POST", "/api/jobs/" + second + "/approve", "not-the-token").status, 401);

  // A worker renders the raised job to its end; the workers list shows it.
  farm_.startWorker("w1", {"--coordinator", address_, "--threads", "1"});
  ASSERT_TRUE(test::waitFor(
      [&] { return json::parse(request(dashboard_, "GET", "/api/jobs/" + second, token_).body)["state"] == "done"; },
      120));
  const json detail = json::parse(request(dashboard_, "GET", "/api/jobs/" + second, token_).body);
  EXPECT_EQ(detail["spp_done"], 64);
  EXPECT_GE(detail["error_history"].size(), 1u);
  EXPECT_FALSE(detail["effects"].empty());
  const json workers = json::parse(request(dashboard_, "GET", "/api/workers", token_).body)["workers"];
  ASSERT_EQ(workers.size(), 1u);
  EXPECT_EQ(workers[0]["name"], "w1");
  EXPECT_EQ(workers[0]["cores"], 1);
  EXPECT_GT(workers[0]["samples_per_second"].get<double>(), 0.0);

  // Images: PNG snapshots whose EV changes the bytes, the full PNG and the EXR as downloads.
  const Reply snapshot = request(dashboard_, "GET", "/api/jobs/" + second + "/snapshot.png?max=32", token_);
  ASSERT_EQ(snapshot.status, 200);
  EXPECT_EQ(snapshot.contentType, "image/png");
  EXPECT_EQ(snapshot.body.substr(0, 8), "\x89PNG\r\n\x1a\n");
  EXPECT_EQ(httplib::detail::get_header_value(snapshot.headers, "X-Samples-Per-Pixel", 0, ""), std::string("64"));
  EXPECT_EQ(httplib::detail::get_header_value(snapshot.headers, "X-Width", 0, ""), std::string("24"))
      << "48 pixels box-filtered by 2 to fit 32";
  const Reply brighter = request(dashboard_, "GET", "/api/jobs/" + second + "/snapshot.png?max=32&ev=2", token_);
  EXPECT_EQ(brighter.status, 200);
  EXPECT_NE(brighter.body, snapshot.body);
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs/" + second + "/snapshot.png?ev=bright", token_).status, 400);
  const Reply png = request(dashboard_, "GET", "/api/jobs/" + second + "/image.png", token_);
  EXPECT_EQ(png.status, 200);
  EXPECT_NE(httplib::detail::get_header_value(png.headers, "Content-Disposition", 0, ""), nullptr);
  const Reply exr = request(dashboard_, "GET", "/api/jobs/" + second + "/image.exr", token_);
  EXPECT_EQ(exr.status, 200);
  EXPECT_EQ(exr.body.substr(0, 4), "\x76\x2f\x31\x01");
  const auto downloaded = farm_.cli({"download", second, "-o", (dir_ / "cli.exr").string(), "--coordinator", address_,
                                     "--token-file", (dir_ / "client.token").string()});
  ASSERT_EQ(downloaded.exitCode, 0) << downloaded.err;
  EXPECT_EQ(exr.body, test::readFile(dir_ / "cli.exr")) << "the same EXR as `lensfarm download`";

  // Another site's form cannot post: actions take JSON only.
  {
    httplib::Client client("127.0.0.1", test::portOf(dashboard_));
    const auto form =
        client.Post(("/api/jobs/" + first + "/cancel").c_str(), httplib::Headers{{"Authorization", "Bearer " + token_}},
                    "x=1", "application/x-www-form-urlencoded");
    ASSERT_TRUE(form);
    EXPECT_EQ(form->status, 415);
  }
  EXPECT_EQ(status(first).find("cancelled"), std::string::npos);

  // Cancel.
  const Reply cancelled = request(dashboard_, "POST", "/api/jobs/" + first + "/cancel", token_);
  EXPECT_EQ(cancelled.status, 200);
  EXPECT_EQ(json::parse(cancelled.body)["state"], "cancelled");
  EXPECT_NE(status(first).find("cancelled"), std::string::npos);
}

// People on the dashboard (--users): a submitter signs in with their own token, sees only their
// jobs when they ask, acts (cap, pause, delete) on their own jobs and not on another's (the page
// offers nothing, and the API refuses); the job page draws its dependencies as a graph.
TEST(DashboardPeople, ARealBrowserShowsAPersonTheirJobsCapsDeletesAndTheDependencyGraph) {
  ASSERT_TRUE(fs::exists(kChromium) && fs::exists(kChromedriver));
  test::TempDir dir;
  test::FarmProcesses farm(dir);
  const std::string admin = "the-administrators-dashboard-token", ann = "anns-own-dashboard-token-1",
                    bob = "bobs-own-dashboard-token-2";
  const fs::path adminFile = dir.write("admin.token", admin + "\n"), annFile = dir.write("ann.token", ann + "\n"),
                 bobFile = dir.write("bob.token", bob + "\n");
  for (const fs::path& f : {adminFile, annFile, bobFile})
    fs::permissions(f, fs::perms::owner_read | fs::perms::owner_write);
  const fs::path users =
      dir.write("users", "ann submitter " + sha256Hex(ann) + "\nbob submitter " + sha256Hex(bob) + "\n");
  fs::permissions(users, fs::perms::owner_read | fs::perms::owner_write);
  const std::string address =
      farm.startCoordinator({"--listen", "127.0.0.1:0", "--client-token-file", adminFile.string(), "--users",
                             users.string(), "--dashboard-listen", "127.0.0.1:0", "--heartbeat-interval", "0.2"});
  const std::string dashboard = farm.dashboardAddress();
  const auto as = [&](const fs::path& token, std::vector<std::string> args) {
    args.insert(args.end(), {"--coordinator", address, "--token-file", token.string()});
    return farm.cli(args);
  };
  const fs::path scene = test::writeSeedScene(dir, 32, 1 << 20, 8);
  const std::string first =
      farm.submit({scene.string(), "--coordinator", address, "--token-file", annFile.string(), "--paused"});
  const std::string bobs =
      farm.submit({scene.string(), "--coordinator", address, "--token-file", bobFile.string(), "--paused"});
  const std::string second = farm.submit(
      {scene.string(), "--coordinator", address, "--token-file", annFile.string(), "--after", first + ":done"});

  Browser browser(dir);
  browser.go("http://" + dashboard + "/");
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#token"); }, 30));
  browser.type("#token", ann);
  browser.click("#token-submit");
  const auto row = [](const std::string& job) { return "#jobs tbody tr[data-job=\"" + job + "\"]"; };
  ASSERT_TRUE(test::waitFor([&] { return browser.visible(row(bobs)); }, 60)) << browser.text("#jobs");
  // Only ann's.
  ASSERT_TRUE(browser.visible("#mine-label"));
  EXPECT_EQ(browser.text("#user-name"), "ann");
  browser.click("#mine");
  ASSERT_TRUE(test::waitFor([&] { return !browser.visible(row(bobs)) && browser.visible(row(first)); }, 30));
  EXPECT_TRUE(browser.visible(row(second)));

  // ann's first job: the graph shows the job waiting for it; she caps it.
  browser.click(row(first) + " a");
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#deps-card"); }, 30)) << "no dependency graph";
  EXPECT_TRUE(browser.visible("#deps a[data-job=\"" + second + "\"]"));
  EXPECT_NE(browser.text("#deps").find("done"), std::string::npos) << browser.text("#deps");
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-dependencies.png");
  browser.type("#max-workers", "1");  // as a person types (a refresh meanwhile keeps it)
  browser.click("#set-cap");
  ASSERT_TRUE(test::waitFor(
      [&] {
        return test::contains(as(adminFile, {"status", first}).out, "max workers: 1");
      },
      30))
      << as(adminFile, {"status", first}).out;

  // bob's job: nothing offered; the API refuses her all the same.
  browser.go("http://" + dashboard + "/#/job/" + bobs);
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-id") == bobs; }, 30));
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-owner") == "bob"; }, 30));
  for (const char* button : {"#cancel", "#delete", "#pause", "#set-cap", "#approve"})
    EXPECT_TRUE(browser.run(std::string("return document.querySelector('") + button + "').disabled;") == true)
        << button;
  const Reply refused = request(dashboard, "POST", "/api/v1/jobs/" + bobs + "/cancel", ann, "");
  EXPECT_EQ(refused.status, 403) << refused.body;
  EXPECT_NE(refused.body.find("ann (submitter) may act on their own jobs only"), std::string::npos) << refused.body;

  // ann deletes her second job from its page (confirming).
  browser.go("http://" + dashboard + "/#/job/" + second);
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-id") == second; }, 30));
  ASSERT_TRUE(
      test::waitFor([&] { return browser.run("return document.querySelector('#delete').disabled;") == false; }, 30));
  browser.run("window.confirm = () => true;");
  browser.click("#delete");
  ASSERT_TRUE(test::waitFor([&] { return browser.run("return location.hash;") == "#/"; }, 30));
  EXPECT_EQ(as(adminFile, {"status", second}).exitCode, 4) << "deleted";
  EXPECT_EQ(as(adminFile, {"status", bobs}).exitCode, 0) << "bob's job is untouched";
}

TEST(DashboardFlags, RefusesAnAddressOpenToTheNetworkWithoutATokenOrMalformed) {
  EXPECT_TRUE(test::helpOf(test::coordinatorPath()).flags.count("--dashboard-listen"));
  const auto open = test::runProcess(
      {test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--dashboard-listen", "0.0.0.0:0"}, 30);
  EXPECT_EQ(open.exitCode, 2);
  EXPECT_NE(open.err.find("refusing to serve the dashboard on 0.0.0.0:0 without --client-token-file"),
            std::string::npos)
      << open.err;
  const auto malformed =
      test::runProcess({test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--dashboard-listen", "8080"}, 30);
  EXPECT_EQ(malformed.exitCode, 2);
  EXPECT_NE(malformed.err.find("--dashboard-listen: expected HOST:PORT"), std::string::npos) << malformed.err;
}

TEST(DashboardFlags, WithoutATokenOnlyLocalhostIsAnswered) {
  test::TempDir dir;
  test::FarmProcesses farm(dir);
  farm.startCoordinator({"--listen", "127.0.0.1:0", "--dashboard-listen", "127.0.0.1:0"});
  EXPECT_EQ(request(farm.dashboardAddress(), "GET", "/api/jobs").status, 200) << "no token needed on loopback";
  httplib::Client client("127.0.0.1", test::portOf(farm.dashboardAddress()));
  const auto rebound = client.Get("/api/jobs", httplib::Headers{{"Host", "evil.example:80"}});
  ASSERT_TRUE(rebound);
  EXPECT_EQ(rebound->status, 403) << "a DNS-rebound name is refused";
  for (const char* host : {"localhost:1", "127.0.0.1:8080", "[::1]:8080"}) {
    const auto ok = client.Get("/api/jobs", httplib::Headers{{"Host", host}});
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->status, 200) << host;
  }
}

TEST_F(DashboardFarm, ARealBrowserWatchesTheImageChangeAndCancels) {
  ASSERT_TRUE(fs::exists(kChromium) && fs::exists(kChromedriver))
      << "needs Debian's chromium and chromium-driver (scripts/setup.sh installs them)";
  // 128x128, 16 spp a unit: a unit every fraction of a second on one thread, for minutes.
  const std::string job = submit(test::writeSeedScene(dir_, 128, 8192, 16));
  farm_.startWorker("w1", {"--coordinator", address_, "--threads", "1"});
  Browser browser(dir_);
  const std::string url = "http://" + dashboard_ + "/";
  browser.go(url);

  // The page asks for the token; a wrong one is refused and said so.
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#token"); }, 30)) << "no token form";
  const json typed = browser.type("#token", "wrong-token");
  const json clicked = browser.click("#token-submit");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#login-error").find("refused") != std::string::npos; }, 30))
      << browser.text("#login-error") << typed.dump() << clicked.dump();
  browser.type("#token", token_);
  browser.click("#token-submit");

  // The job list and the worker list.
  const std::string row = "#jobs tbody tr[data-job=\"" + job + "\"]";
  ASSERT_TRUE(
      test::waitFor([&] { return browser.visible(row) && browser.text(row).find("running") != std::string::npos; }, 60))
      << browser.text("#jobs");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#workers tbody").find("unit") != std::string::npos; }, 30))
      << browser.text("#workers");
  EXPECT_NE(browser.text("#workers tbody").find("w1"), std::string::npos);
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-overview.png");

  // The lists refresh every second without replacing what did not change: the job's link is the
  // same node a poll later, so a click (press and release) on it is never lost.
  const auto polled = [&] { return browser.text("#connection"); };
  browser.run("document.querySelector('" + row + " a').lensfarmMarked = 'yes';");
  const std::string lastPoll = polled();
  ASSERT_TRUE(test::waitFor([&] { return polled() != lastPoll; }, 30)) << "the overview is not refreshed";
  EXPECT_EQ(browser.run("const a = document.querySelector('" + row + " a'); return a ? a.lensfarmMarked || '' : null;"),
            "yes");

  // The job page: the image on it changes as samples arrive.
  browser.click(row + " a");
  ASSERT_TRUE(test::waitFor([&] { return browser.run("return location.hash;") == "#/job/" + job; }, 30))
      << browser.run("return location.hash;").dump();
  const auto shown = [&] {
    const json v = browser.run(
        "const i = document.querySelector('#snapshot'); return [i.dataset.hash || '', i.dataset.spp || '', "
        "i.naturalWidth];");
    return v.is_array() && v.size() == 3 ? v : json::array({"", "", 0});
  };
  ASSERT_TRUE(test::waitFor([&] { return !shown()[0].get<std::string>().empty(); }, 30)) << "no image on the job page";
  const json before = shown();
  EXPECT_EQ(before[2], 128);
  ASSERT_TRUE(test::waitFor(
      [&] {
        const json now = shown();
        return now[0] != before[0] && std::stoul(now[1].get<std::string>()) > std::stoul(before[1].get<std::string>());
      },
      60))
      << "the image did not change: " << before.dump();
  // Wait for a few points of the error curve, so the screenshot shows one.
  ASSERT_TRUE(test::waitFor(
      [&] { return browser.run("return Number(document.querySelector('#error-chart').dataset.points || 0);") >= 3; },
      60));
  EXPECT_NE(browser.text("#effects").find("depth of field"), std::string::npos) << browser.text("#effects");
  EXPECT_EQ(browser.text("#job-state"), "running");
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard.png");

  // Pause, resume and approve (docs/farm.md "Scheduling"): the page and the coordinator agree.
  browser.click("#pause");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#pause") == "Resume"; }, 30)) << browser.text("#pause");
  EXPECT_NE(browser.text("#job-paused").find("no unit is leased"), std::string::npos);
  EXPECT_NE(status(job).find("paused:     yes"), std::string::npos) << status(job);
  browser.click("#pause");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#pause") == "Pause"; }, 30)) << browser.text("#pause");
  EXPECT_EQ(status(job).find("paused:     yes"), std::string::npos) << status(job);
  browser.click("#approve");
  ASSERT_TRUE(
      test::waitFor([&] { return browser.run("return document.querySelector('#approve').disabled;") == true; }, 30));
  EXPECT_NE(status(job).find("approved:   yes"), std::string::npos) << status(job);

  // Cancel: the page and the coordinator agree.
  browser.click("#cancel");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-state") == "cancelled"; }, 30))
      << browser.text("#job-state");
  EXPECT_TRUE(
      test::waitFor([&] { return browser.run("return document.querySelector('#cancel').disabled;") == true; }, 10));
  EXPECT_NE(status(job).find("cancelled"), std::string::npos) << status(job);
  EXPECT_TRUE(browser.run("return document.querySelector('#priority-up').disabled;") == true);

  // The EV slider re-exposes the (now fixed) image.
  const json settled = shown();
  browser.run(
      "const e = document.querySelector('#ev'); e.value = '2'; e.dispatchEvent(new Event('input'));"
      "e.dispatchEvent(new Event('change'));");
  EXPECT_TRUE(
      test::waitFor([&] { return browser.text("#snapshot-caption").find("+2.00 EV") != std::string::npos; }, 30))
      << browser.text("#snapshot-caption");
  EXPECT_NE(shown()[0], settled[0]) << "a brighter exposure is another PNG";
  EXPECT_EQ(shown()[1], settled[1]) << "of the same samples";
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-cancelled.png");

  // Downloads are fetched with the token and saved through a blob link (the token is in no URL).
  browser.run(
      "window.savedLinks = []; HTMLAnchorElement.prototype.click = function() {"
      " window.savedLinks.push([this.download, this.href]); };");
  for (const std::string kind : {"exr", "png"}) {
    browser.click("#download-" + kind);
    ASSERT_TRUE(test::waitFor([&] { return browser.run("return window.savedLinks.length;").get<int>() > 0; }, 30))
        << kind;
    const json link = browser.run("return window.savedLinks.shift();");
    EXPECT_EQ(link[0], job + "." + kind);
    EXPECT_EQ(link[1].get<std::string>().rfind("blob:", 0), 0u) << link.dump();
    const json head = browser.run("return fetch(" + link[1].dump() +
                                  ").then(r => r.arrayBuffer()).then(b => Array.from(new Uint8Array(b.slice(0, 4))));");
    EXPECT_EQ(head, kind == "exr" ? json({0x76, 0x2f, 0x31, 0x01}) : json({0x89, 0x50, 0x4e, 0x47})) << kind;
  }
  EXPECT_GT(fs::file_size(fs::path(LENSFARM_BINARY_DIR) / "dashboard.png"), 10000u);
}

TEST_F(DashboardFarm, ARealBrowserShowsProgressWithoutASampleCapAndALostWorker) {
  ASSERT_TRUE(fs::exists(kChromium) && fs::exists(kChromedriver))
      << "needs Debian's chromium and chromium-driver (scripts/setup.sh installs them)";
  // No --spp: the job runs to a target error it will not reach, or its deadline; the bar shows
  // the nearer (the deadline), never units out of the internal cap of 2^40 samples per pixel.
  const std::string job =
      submit(test::writeSeedScene(dir_, 64, 8, 8), {"--target-error", "0.0001", "--deadline", "2m"});
  test::ChildProcess& worker = farm_.startWorker("w1", {"--coordinator", address_, "--threads", "1"});
  Browser browser(dir_);
  browser.go("http://" + dashboard_ + "/");
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#token"); }, 30)) << "no token form";
  browser.type("#token", token_);
  browser.click("#token-submit");

  const std::string row = "#jobs tbody tr[data-job=\"" + job + "\"]";
  const auto barWidth = [&](const std::string& css) {
    const json v = browser.run("const e = document.querySelector(" + json(css).dump() +
                               "); return e ? parseFloat(e.style.width) : -1;");
    return v.is_number() ? v.get<double>() : -1.0;
  };
  ASSERT_TRUE(test::waitFor([&] { return browser.visible(row) && barWidth(row + " .progress div") > 0.0; }, 60))
      << browser.text("#jobs") << " bar " << barWidth(row + " .progress div");
  EXPECT_EQ(browser.text(row).find("1099511627776"), std::string::npos) << browser.text(row);
  const std::string workerRow = "#workers tbody tr[data-worker]";
  ASSERT_TRUE(test::waitFor([&] { return browser.text(workerRow).find("w1") != std::string::npos; }, 30))
      << browser.text("#workers");

  // The worker dies: the list says lost (and why) at once, and the job why it is stalled.
  worker.signal(SIGKILL);
  const std::string lostRow = "#workers tbody tr[data-state=\"lost\"]";
  ASSERT_TRUE(test::waitFor([&] { return browser.visible(lostRow); }, 10)) << browser.text("#workers");
  EXPECT_NE(browser.text(lostRow).find("w1"), std::string::npos) << browser.text(lostRow);
  EXPECT_NE(browser.text(lostRow).find("connection broke"), std::string::npos) << browser.text(lostRow);
  ASSERT_TRUE(test::waitFor([&] { return browser.text(row + " .time-left") == "stalled"; }, 10)) << browser.text(row);
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-lost-worker.png");

  browser.click(row + " a");
  ASSERT_TRUE(
      test::waitFor([&] { return browser.text("#job-stalled").find("no workers connected") != std::string::npos; }, 30))
      << browser.text("#job-stats");
  // Which worker was lost, whether it held one of this job's units at that moment ("worker w1 (...)
  // lost 1 s ago (...); unit 3 queued again; ...") or was between units ("... (w1 (...) lost ...)").
  EXPECT_NE(browser.text("#job-stalled").find("w1 (worker-"), std::string::npos) << browser.text("#job-stalled");
  EXPECT_NE(browser.text("#job-stalled").find(" lost "), std::string::npos) << browser.text("#job-stalled");
  EXPECT_EQ(browser.text("#job-time-left"), "stalled");
  EXPECT_NE(browser.text("#job-progress-text").find("toward error 0.01 % or deadline 2 min 00 s"), std::string::npos)
      << browser.text("#job-progress-text");
  EXPECT_GT(barWidth("#job-progress-bar"), 0.0);
  EXPECT_EQ(browser.text("#job-spp").find("/"), std::string::npos) << "no total: " << browser.text("#job-spp");
}

// The page with what the cross-worker audit reports (docs/farm.md "Audit"): a quarantined worker
// with the reason, and a job's audit counts and events. No worker here renders wrongly on purpose,
// so the page is served from its source files by this test, its /api answering with the
// coordinator's own JSON (dashboard.h) of a hand-filled job and workers (audit_views.h).
TEST(DashboardPage, ARealBrowserShowsAQuarantinedWorkerAndAJobsAuditAndEvents) {
  ASSERT_TRUE(fs::exists(kChromium) && fs::exists(kChromedriver))
      << "needs Debian's chromium and chromium-driver (scripts/setup.sh installs them)";
  const fs::path page = fs::path(LENSFARM_SOURCE_DIR) / "coordinator" / "web" / "dashboard";
  const JobInfo audited = test::auditedJob();
  JobInfo plain;  // no audit yet, no events
  plain.id = "job-8";
  plain.state = JobState::kQueued;
  plain.sceneName = "plain.json";
  plain.width = plain.height = 16;
  const std::map<std::string, std::string> details = {{audited.id, jobDetailJson(audited, {})},
                                                      {plain.id, jobDetailJson(plain, {})}};
  Image pixels;
  pixels.width = pixels.height = 16;
  pixels.rgb.assign(16 * 16 * 3, 0.5f);
  const std::string png = encodePng(pixels, ExposureSettings{});

  httplib::Server server;
  for (const auto& [path, file, type] :
       {std::tuple{"/", "index.html", "text/html"}, std::tuple{"/app.js", "app.js", "text/javascript"},
        std::tuple{"/style.css", "style.css", "text/css"}}) {
    const std::string body = test::readFile(page / file), contentType = type;
    server.Get(
        path, [body, contentType](const httplib::Request&, httplib::Response& r) { r.set_content(body, contentType); });
  }
  server.Get("/api/jobs", [&](const httplib::Request&, httplib::Response& r) {
    json jobs = json::array();
    for (const auto& [id, detail] : details) jobs.push_back(json::parse(detail));
    r.set_content(json{{"jobs", jobs}}.dump(), "application/json");
  });
  server.Get("/api/workers", [&](const httplib::Request&, httplib::Response& r) {
    r.set_content(workerListJson(test::auditedWorkers()), "application/json");
  });
  server.Get(R"(/api/jobs/([^/]+)/snapshot\.png)", [&](const httplib::Request&, httplib::Response& r) {
    for (const auto& [name, value] : {std::pair{"X-Job-Version", "1"}, std::pair{"X-Samples-Per-Pixel", "96"},
                                      std::pair{"X-Ev", "0"}, std::pair{"X-Width", "16"}, std::pair{"X-Height", "16"}})
      r.set_header(name, value);
    r.set_content(png, "image/png");
  });
  server.Get(R"(/api/jobs/([^/]+))", [&](const httplib::Request& request, httplib::Response& r) {
    const auto detail = details.find(request.matches[1].str());
    if (detail == details.end())
      r.status = 404;
    else
      r.set_content(detail->second, "application/json");
  });
  const int port = server.bind_to_any_port("127.0.0.1");
  ASSERT_GT(port, 0);
  std::thread serving([&] { server.listen_after_bind(); });
  struct Stop {
    httplib::Server& server;
    std::thread& thread;
    ~Stop() {
      server.stop();
      thread.join();
    }
  } stop{server, serving};

  test::TempDir dir;
  Browser browser(dir);
  browser.go("http://127.0.0.1:" + std::to_string(port) + "/");
  const std::string quarantined = "#workers tbody tr[data-state=\"quarantined\"]";
  ASSERT_TRUE(test::waitFor([&] { return browser.visible(quarantined); }, 30)) << browser.text("#workers");
  EXPECT_NE(browser.text(quarantined).find("box-3"), std::string::npos) << browser.text(quarantined);
  EXPECT_EQ(browser.text(quarantined + " .badge"), "quarantined");
  EXPECT_EQ(browser.text(quarantined + " .quarantine-reason"), test::kQuarantineReason);
  const std::string healthy = "#workers tbody tr[data-worker=\"w1\"]";
  EXPECT_EQ(browser.text(healthy).find("quarantined"), std::string::npos) << browser.text(healthy);
  EXPECT_EQ(browser.text(healthy + " .badge"), "rendering");
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-quarantined-worker.png");

  browser.click("#jobs tbody tr[data-job=\"job-7\"] a");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-id") == "job-7" && browser.visible("#events-card"); }, 30))
      << browser.text("#job-stats");
  EXPECT_EQ(browser.text("#job-audit"), "12 passed, 1 failed, 2 pending; 40 units rendered again");
  EXPECT_EQ(browser.run("return document.querySelectorAll('#events li').length;"), 2);
  EXPECT_NE(browser.text("#events li:first-child").find(audited.events[0].text), std::string::npos)
      << browser.text("#events");
  EXPECT_NE(browser.text("#events li:last-child").find(audited.events[1].text), std::string::npos)
      << browser.text("#events");
  const std::string shownTime =
      browser.run("return new Date(" + std::to_string(1000 * audited.events[0].unixSeconds) + ").toLocaleString();");
  EXPECT_NE(browser.text("#events li:first-child").find(shownTime), std::string::npos) << "in the browser's local time";
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-audit-events.png");

  // A job with nothing to say of the audit shows neither the counts nor the events.
  browser.go("http://127.0.0.1:" + std::to_string(port) + "/#/job/job-8");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-id") == "job-8" && browser.visible("#job-stats"); }, 30));
  EXPECT_FALSE(browser.visible("#events-card"));
  EXPECT_FALSE(browser.visible("#job-audit"));
}

// ---- the viewer token and HTTPS ----------------------------------------------------------------

// A coordinator with all three tokens (client, worker, viewer) and its dashboard; with `tls`, the
// gRPC services and the dashboard use a throwaway certificate for 127.0.0.1 (ca.pem signed it).
class DashboardAccess : public ::testing::Test {
 protected:
  // A server that refuses a TLS handshake (no client certificate) closes the socket while the
  // in-process client may still write to it: that write must fail (EPIPE), not kill the tests.
  static void SetUpTestSuite() { signal(SIGPIPE, SIG_IGN); }
  void start(bool tls, const std::vector<std::string>& extra = {}) {
    if (tls) test::makeCertificates(dir_, "IP:127.0.0.1,DNS:localhost");
    std::vector<std::string> args = {"--listen", "127.0.0.1:0", "--dashboard-listen", "127.0.0.1:0"};
    for (const std::string who : {"client", "worker", "viewer"}) {
      const std::string& token = who == "client" ? client_ : who == "worker" ? worker_ : viewer_;
      args.insert(args.end(), {"--" + who + "-token-file", dir_.write(who + ".token", token + "\n").string()});
    }
    if (tls) args.insert(args.end(), {"--tls-cert", p("server.pem"), "--tls-key", p("server.key")});
    args.insert(args.end(), extra.begin(), extra.end());
    address_ = farm_.startCoordinator(args);
    dashboard_ = farm_.dashboardAddress();
    ASSERT_FALSE(dashboard_.empty());
  }
  std::string p(const std::string& name) const { return (dir_ / name).string(); }
  // The `lensfarm` CLI against the coordinator with a token file (and the CA when it serves TLS).
  test::ProcessResult cli(std::vector<std::string> args, const std::string& tokenFile, bool tls = false) {
    args.insert(args.end(), {"--coordinator", address_, "--token-file", p(tokenFile)});
    if (tls) args.insert(args.end(), {"--tls-ca", p("ca.pem")});
    return farm_.cli(args);
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  const std::string client_ = "client-token-of-the-access-test", worker_ = "worker-token-of-the-access-test",
                    viewer_ = "viewer-token-of-the-access-test";
  std::string address_, dashboard_;
};

// The viewer token reads everything the dashboard shows and changes nothing; on the gRPC services
// it is no token at all (not even for reading). Wrong or missing tokens get 401 and nothing else.
TEST_F(DashboardAccess, TheViewerTokenReadsTheDashboardButCannotActNorCallGrpc) {
  ASSERT_NO_FATAL_FAILURE(start(false));
  const std::string job = farm_.submit({test::writeSeedScene(dir_, 32, 1 << 20, 8).string(), "--coordinator", address_,
                                        "--token-file", p("client.token")});
  const std::string jobPath = "/api/jobs/" + job;

  for (const std::string& path : std::vector<std::string>{"/api/jobs", "/api/workers", jobPath,
                                                          jobPath + "/snapshot.png", jobPath + "/image.exr"}) {
    SCOPED_TRACE(path);
    const Reply missing = request(dashboard_, "GET", path), wrong = request(dashboard_, "GET", path, worker_);
    EXPECT_EQ(missing.status, 401);
    EXPECT_EQ(wrong.status, 401) << "the worker token opens nothing on the dashboard";
    EXPECT_EQ(json::parse(missing.body, nullptr, false), json({{"error", "missing client or viewer token"}}));
    EXPECT_EQ(json::parse(wrong.body, nullptr, false), json({{"error", "wrong client or viewer token"}}));
    const Reply asViewer = request(dashboard_, "GET", path, viewer_),
                asClient = request(dashboard_, "GET", path, client_);
    EXPECT_EQ(asViewer.status, 200) << asViewer.body;
    EXPECT_EQ(asClient.status, 200) << asClient.body;
    EXPECT_EQ(asViewer.contentType, asClient.contentType);
    EXPECT_EQ(httplib::detail::get_header_value(asViewer.headers, "X-Lensfarm-Access", 0, ""), std::string("read"));
    EXPECT_EQ(httplib::detail::get_header_value(asClient.headers, "X-Lensfarm-Access", 0, ""), std::string("full"));
  }
  EXPECT_EQ(json::parse(request(dashboard_, "GET", "/api/jobs", viewer_).body)["jobs"][0]["id"], job);

  // Actions: 403 for the viewer, and the job is untouched.
  const Reply cancel = request(dashboard_, "POST", jobPath + "/cancel", viewer_);
  EXPECT_EQ(cancel.status, 403);
  EXPECT_NE(cancel.body.find("viewer token is read-only"), std::string::npos) << cancel.body;
  EXPECT_EQ(request(dashboard_, "POST", jobPath + "/priority", viewer_, R"({"priority": 7})").status, 403);
  EXPECT_EQ(request(dashboard_, "POST", jobPath + "/cancel", "").status, 401);
  const json after = json::parse(request(dashboard_, "GET", jobPath, client_).body);
  EXPECT_EQ(after["state"], "queued");
  EXPECT_EQ(after["priority"], 0);

  // gRPC: the viewer token reads (status, workers) but changes nothing (PERMISSION_DENIED, exit
  // 6), and the worker service refuses it.
  for (const auto& call : std::vector<std::vector<std::string>>{{"status"}, {"status", job}, {"workers"}}) {
    const auto r = cli(call, "viewer.token");
    EXPECT_EQ(r.exitCode, 0) << call[0] << ": " << r.err;
  }
  const auto cancelled = cli({"cancel", job}, "viewer.token");
  EXPECT_EQ(cancelled.exitCode, 6) << cancelled.err;
  EXPECT_NE(cancelled.err.find("CancelJob: the viewer token is read-only"), std::string::npos) << cancelled.err;
  const auto submitted = cli({"submit", test::writeSeedScene(dir_, 16, 8, 8).string()}, "viewer.token");
  EXPECT_EQ(submitted.exitCode, 6) << submitted.err;
  EXPECT_NE(submitted.err.find("the viewer token is read-only"), std::string::npos) << submitted.err;
  test::ChildProcess& impostor =
      farm_.startWorker("viewer-as-worker", {"--coordinator", address_, "--token-file", p("viewer.token")});
  EXPECT_EQ(impostor.wait(30), 3) << impostor.log();
  EXPECT_NE(impostor.log().find("wrong worker token"), std::string::npos) << impostor.log();
  EXPECT_NE(cli({"status", job}, "client.token").out.find("queued"), std::string::npos) << "nothing changed the job";

  // The client token still does everything.
  EXPECT_EQ(request(dashboard_, "POST", jobPath + "/cancel", client_).status, 200);
  const std::string log = farm_.coordinator().log();
  EXPECT_NE(log.find("viewer token accepted (read-only)"), std::string::npos) << log;
  EXPECT_NE(log.find("dashboard: refused POST " + jobPath + "/cancel from"), std::string::npos) << log;
  for (const std::string& secret : {client_, worker_, viewer_})
    EXPECT_EQ(log.find(secret), std::string::npos) << "never logged";
}

// With --tls-cert the dashboard is HTTPS with the gRPC services' certificate: a client that trusts
// the farm's CA (and checks the host) reads it with a token, plain HTTP gets no answer, and the
// tokens work as without TLS.
TEST_F(DashboardAccess, ServedOverHttpsWithTheCoordinatorsCertificate) {
  ASSERT_NO_FATAL_FAILURE(start(true));
  const Https https{p("ca.pem"), "", ""};
  const Reply jobs = request(dashboard_, "GET", "/api/jobs", client_, "", https);
  EXPECT_EQ(jobs.status, 200) << httplib::to_string(jobs.error);
  EXPECT_EQ(json::parse(jobs.body, nullptr, false), json({{"jobs", json::array()}}));
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs", viewer_, "", https).status, 200);
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs", "", "", https).status, 401);
  EXPECT_EQ(request(dashboard_, "POST", "/api/jobs/job-1/cancel", viewer_, "", https).status, 403);
  EXPECT_EQ(request(dashboard_, "GET", "/", "", "", https).contentType.rfind("text/html", 0), 0u);

  // Plain HTTP on the HTTPS port: the handshake fails, no HTTP answer at all.
  const Reply plain = request(dashboard_, "GET", "/api/jobs", client_);
  EXPECT_EQ(plain.status, 0) << plain.body;
  // A client that does not trust the farm's CA refuses the certificate (the client certificate is
  // signed by nothing it trusts as a CA).
  const Reply untrusted = request(dashboard_, "GET", "/api/jobs", client_, "", Https{p("client.pem"), "", ""});
  EXPECT_EQ(untrusted.status, 0);
  EXPECT_EQ(untrusted.error, httplib::Error::SSLServerVerification) << httplib::to_string(untrusted.error);

  // The gRPC services keep their TLS (the same certificate) and the CLI still works with it.
  EXPECT_EQ(cli({"status"}, "client.token", true).exitCode, 0);
  EXPECT_NE(farm_.coordinator().log().find("dashboard on https://" + dashboard_ + "/"), std::string::npos)
      << farm_.coordinator().log();
}

// With --tls-client-ca the dashboard, like the gRPC services, takes only connections with a client
// certificate signed by that CA, and still asks for a token.
TEST_F(DashboardAccess, MutualTlsNeedsAClientCertificateAndAToken) {
  ASSERT_NO_FATAL_FAILURE(start(true, {"--tls-client-ca", (dir_ / "ca.pem").string()}));
  const Reply anonymous = request(dashboard_, "GET", "/api/jobs", client_, "", Https{p("ca.pem"), "", ""});
  EXPECT_EQ(anonymous.status, 0) << "no client certificate, no connection";
  const Https withCertificate{p("ca.pem"), p("client.pem"), p("client.key")};
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs", viewer_, "", withCertificate).status, 200);
  EXPECT_EQ(request(dashboard_, "GET", "/api/jobs", "", "", withCertificate).status, 401);
}

TEST(DashboardFlags, AViewerTokenNeedsAClientTokenAndOneOfItsOwn) {
  EXPECT_TRUE(test::helpOf(test::coordinatorPath()).flags.count("--viewer-token-file"));
  EXPECT_NE(test::helpOf(test::coordinatorPath()).text.find("LENSFARM_VIEWER_TOKEN"), std::string::npos);
  test::TempDir dir;
  const std::string client = dir.write("client.token", "Y2xpZW50LXNpZGUtcmFuZG9tLXRva2VuLTQ1Ng==\n").string();
  const std::string worker = dir.write("worker.token", "d29ya2VyLXNpZGUtcmFuZG9tLXRva2VuLTc4OQ==\n").string();
  const std::string viewer = dir.write("viewer.token", "dmlld2VyLXNpZGUtcmFuZG9tLXRva2VuLTAxMg==\n").string();
  const std::string weak = dir.write("weak.token", "REPLACE-ME-viewer-token\n").string();
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {test::coordinatorPath().string(), "--listen", "127.0.0.1:0"});
    return test::runProcess(args, 30);
  };
  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--viewer-token-file", viewer}, "--viewer-token-file: a viewer token needs a client token"},
           {{"--client-token-file", client, "--viewer-token-file", client},
            "--viewer-token-file: viewers need a token of their own"},
           {{"--client-token-file", client, "--worker-token-file", worker, "--viewer-token-file", worker},
            "--viewer-token-file: viewers need a token of their own"},
           {{"--client-token-file", client, "--viewer-token-file", weak}, weak + ": the token is a placeholder"}}) {
    const auto r = run(args);
    EXPECT_EQ(r.exitCode, 2) << message;
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
  }
  // LENSFARM_VIEWER_TOKEN works like the file (checked the same way).
  const auto fromEnvironment =
      test::runProcess({"/usr/bin/env", "LENSFARM_VIEWER_TOKEN=REPLACE-ME-viewer-token",
                        test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--client-token-file", client},
                       30);
  EXPECT_EQ(fromEnvironment.exitCode, 2);
  EXPECT_NE(fromEnvironment.err.find("LENSFARM_VIEWER_TOKEN"), std::string::npos) << fromEnvironment.err;
}

// A person with the viewer token opens the HTTPS dashboard in a real browser: the page loads over
// TLS, takes the token in its form, shows the job, says "read-only" and offers no Cancel or
// priority buttons; the client token in the same tab brings them back.
TEST_F(DashboardAccess, ARealBrowserOpensTheHttpsDashboardWithTheViewerToken) {
  ASSERT_TRUE(fs::exists(kChromium) && fs::exists(kChromedriver))
      << "needs Debian's chromium and chromium-driver (scripts/setup.sh installs them)";
  ASSERT_NO_FATAL_FAILURE(start(true));
  const std::string job =
      cli({"submit", test::writeSeedScene(dir_, 32, 1 << 20, 8).string()}, "client.token", true).out;
  const std::string id = job.substr(0, job.find('\n'));
  ASSERT_FALSE(id.empty());
  Browser browser(dir_, true);
  browser.go("https://" + dashboard_ + "/#/job/" + id);
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#token"); }, 30)) << "no token form";
  browser.type("#token", viewer_);
  browser.click("#token-submit");
  ASSERT_TRUE(test::waitFor([&] { return browser.text("#job-id") == id && browser.visible("#job-stats"); }, 30))
      << browser.text("#login-error");
  EXPECT_EQ(browser.run("return location.protocol;"), "https:");
  EXPECT_EQ(browser.text("#job-state"), "queued");
  EXPECT_TRUE(browser.visible("#read-only"));
  EXPECT_TRUE(browser.run("return document.querySelector('#cancel').disabled;") == true) << "a viewer cannot cancel";
  EXPECT_TRUE(browser.run("return document.querySelector('#priority-up').disabled;") == true);
  browser.screenshot(fs::path(LENSFARM_BINARY_DIR) / "dashboard-viewer.png");

  // The client token in the same tab: the actions are offered again.
  browser.click("#forget-token");
  ASSERT_TRUE(test::waitFor([&] { return browser.visible("#token"); }, 30));
  browser.type("#token", client_);
  browser.click("#token-submit");
  ASSERT_TRUE(
      test::waitFor([&] { return browser.run("return document.querySelector('#cancel').disabled;") == false; }, 30));
  EXPECT_FALSE(browser.visible("#read-only"));
}

}  // namespace
}  // namespace lensfarm
