// Hostile clients against a real coordinator's HTTP ports (the dashboard and the metrics
// endpoint; coordinator/web/http_server.h), over raw sockets on loopback: oversized bodies and
// headers, slow and idle connections, floods of connections, rebinding Host names, bad framing.
// Each test asserts a bound (the coordinator's peak memory, the time a legitimate call takes
// while the attack runs, the status and how soon it comes) and prints it.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "tests/deploy_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// A raw TCP connection to 127.0.0.1:PORT (a test fails if it cannot connect).
class RawConnection {
 public:
  explicit RawConnection(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(uint16_t(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    EXPECT_TRUE(connected_) << "connect to port " << port;
  }
  ~RawConnection() { ::close(fd_); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  // Sends all of `bytes`; false once the peer has closed or reset.
  bool send(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      bytes.remove_prefix(size_t(n));
    }
    return true;
  }
  // Everything received until the peer closes or `seconds` pass.
  std::string receive(double seconds) {
    std::string out;
    const auto end = Clock::now() + std::chrono::duration<double>(seconds);
    char buffer[65536];
    while (Clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      const int wait = int(std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count());
      if (::poll(&p, 1, std::max(wait, 1)) <= 0) continue;
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) break;
      out.append(buffer, size_t(n));
    }
    return out;
  }
  // Whether something (an answer, or the close) has arrived.
  bool readable() {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, 0) > 0;
  }
  // The status code of the first response received within `seconds`, or 0.
  int status(double seconds) {
    const std::string response = receive(seconds);
    if (response.rfind("HTTP/1.1 ", 0) != 0) return 0;
    return std::atoi(response.c_str() + 9);
  }

 private:
  int fd_;
  bool connected_ = false;
};

// A kB figure of /proc/PID/status ("VmRSS", "VmHWM").
long procStatusKb(int pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field + ":", 0) == 0) return std::atol(line.c_str() + field.size() + 1);
  return -1;
}

int threadsOf(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("Threads:", 0) == 0) return std::atoi(line.c_str() + 8);
  return -1;
}

std::string get(const std::string& path, const std::string& token = "", const std::string& host = "127.0.0.1") {
  std::string request = "GET " + path + " HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n";
  if (!token.empty()) request += "Authorization: Bearer " + token + "\r\n";
  return request + "\r\n";
}

class HostileHttp : public ::testing::Test {
 protected:
  void SetUp() override {
    token_ = "client-token-for-the-hostile-http-test";
    const fs::path tokenFile = dir_.write("client.token", token_ + "\n");
    fs::permissions(tokenFile, fs::perms::owner_read | fs::perms::owner_write);
    farm_.startCoordinator({"--listen", "127.0.0.1:0", "--client-token-file", tokenFile.string(), "--dashboard-listen",
                            "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0"});
    dashboard_ = test::portOf(farm_.dashboardAddress());
    metrics_ = test::portOf(farm_.metricsAddress());
  }

  // Seconds a legitimate, authorised GET /api/jobs takes to answer 200 (a large value if it fails).
  double legitimateCall() {
    const auto start = Clock::now();
    RawConnection connection(dashboard_);
    connection.send(get("/api/jobs", token_));
    const int status = connection.status(30);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return status == 200 ? seconds : 1e9;
  }
  double metricsCall() {
    const auto start = Clock::now();
    RawConnection connection(metrics_);
    connection.send(get("/metrics"));
    const int status = connection.status(30);
    return status == 200 ? std::chrono::duration<double>(Clock::now() - start).count() : 1e9;
  }
  long peakKb() { return procStatusKb(farm_.coordinator().pid(), "VmHWM"); }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  std::string token_;
  int dashboard_ = 0, metrics_ = 0;
};

// 1 GiB bodies, declared or chunked, with and without the token, to a route, to no route and to
// the metrics port: each is refused from its header (the route first: 404, 405; then the token:
// 401; then the length: 413) while the sender is still sending, and the coordinator's peak memory
// does not move.
TEST_F(HostileHttp, OversizedBodiesAreRefusedWithoutBeingRead) {
  const long before = peakKb();
  const std::string chunk(1 << 20, 'x');
  struct Case {
    int port;
    std::string head;
    bool chunked;
    int status;
  };
  const std::string auth = "Authorization: Bearer " + token_ + "\r\n";
  const std::vector<Case> cases = {
      {dashboard_,
       "POST /api/jobs/job-1/cancel HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
       "Content-Length: 1073741824\r\n\r\n",
       false, 401},
      {dashboard_,
       "POST /api/jobs/job-1/priority HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n" + auth +
           "Content-Length: 1073741824\r\n\r\n",
       false, 413},
      {dashboard_,
       "POST /api/jobs/job-1/priority HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n" + auth +
           "Transfer-Encoding: chunked\r\n\r\n",
       true, 413},
      {dashboard_, "POST /no/such/route HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1073741824\r\n\r\n", false, 404},
      {metrics_, "POST /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1073741824\r\n\r\n", false, 405},
      {metrics_, "GET /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 1073741824\r\n\r\n", false, 413},
  };
  for (const Case& c : cases) {
    RawConnection connection(c.port);
    ASSERT_TRUE(connection.send(c.head));
    // Keep sending the body (up to 1 GiB) until the coordinator closes; read its answer meanwhile.
    std::atomic<bool> stop{false};
    size_t sent = 0;
    std::thread sender([&] {
      const std::string piece = c.chunked ? "100000\r\n" + chunk + "\r\n" : chunk;
      while (!stop && sent < (size_t(1) << 30) && connection.send(piece)) sent += piece.size();
    });
    const int status = connection.status(30);
    stop = true;
    sender.join();
    EXPECT_EQ(status, c.status) << c.head;
    EXPECT_LT(sent, size_t(1) << 30) << "the coordinator read the whole body: " << c.head;
  }
  const long after = peakKb();
  std::printf("coordinator peak RSS %ld kB before, %ld kB after six 1 GiB requests (+%ld kB)\n", before, after,
              after - before);
  EXPECT_LT(after - before, 16 * 1024) << "peak RSS grew by " << after - before << " kB";
  EXPECT_LT(legitimateCall(), 5.0);
}

// Headers: 200 MB of one field, 200 MB of many fields, 101 small fields: 431 from the first 16 KiB.
TEST_F(HostileHttp, OversizedHeadersAreRefusedEarly) {
  const long before = peakKb();
  for (const std::string& field : {std::string("X-Big: "), std::string("")}) {
    RawConnection connection(dashboard_);
    ASSERT_TRUE(connection.send("GET /api/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n" + field));
    std::atomic<bool> stop{false};
    size_t sent = 0;
    std::thread sender([&] {
      const std::string piece = field.empty() ? [] {
        std::string many;
        for (int i = 0; i < 20000; ++i) many += "X-F" + std::to_string(i) + ": v\r\n";
        return many;
      }()
                                              : std::string(1 << 20, 'a');
      while (!stop && sent < 200'000'000 && connection.send(piece)) sent += piece.size();
    });
    const int status = connection.status(30);
    stop = true;
    sender.join();
    EXPECT_EQ(status, 431) << (field.empty() ? "many fields" : "one long field");
    EXPECT_LT(sent, size_t(200'000'000));
  }
  std::string fields;
  for (int i = 0; i < 101; ++i) fields += "X-F" + std::to_string(i) + ": v\r\n";
  RawConnection many(dashboard_);
  many.send("GET /api/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\n" + fields + "\r\n");
  const std::string reply = many.receive(10);
  EXPECT_EQ(reply.rfind("HTTP/1.1 431", 0), 0u) << reply;
  EXPECT_NE(reply.find("more than 100 header fields"), std::string::npos) << reply;
  const long after = peakKb();
  std::printf("coordinator peak RSS +%ld kB after 400 MB of headers\n", after - before);
  EXPECT_LT(after - before, 16 * 1024);
}

// Slowloris: 100 connections to the dashboard and 100 to the metrics port, each sending one
// header byte every 0.5 s. Legitimate calls answer within a second throughout; each slow
// connection is answered 408 at the header deadline (10 s from its first byte, not per byte).
TEST_F(HostileHttp, SlowClientsHoldNoThreadAndAreCutOffAtTheHeaderDeadline) {
  const int threadsBefore = threadsOf(farm_.coordinator().pid());
  const std::string request = get("/api/jobs", token_);
  std::vector<std::unique_ptr<RawConnection>> slow;
  for (int i = 0; i < 100; ++i) {
    slow.push_back(std::make_unique<RawConnection>(dashboard_));
    slow.push_back(std::make_unique<RawConnection>(metrics_));
  }
  const auto start = Clock::now();
  double worstDashboard = 0, worstMetrics = 0;
  size_t byte = 0;
  std::vector<double> answeredAfter(slow.size(), 0);  // seconds from the first byte to the 408
  int answered408 = 0;
  while (Clock::now() - start < std::chrono::seconds(14)) {
    for (size_t k = 0; k < slow.size(); ++k) {
      if (answeredAfter[k] > 0) continue;
      if (slow[k]->readable()) {
        answeredAfter[k] = std::chrono::duration<double>(Clock::now() - start).count();
        answered408 += slow[k]->status(1) == 408;
      } else {
        slow[k]->send(std::string_view(request).substr(byte % 8, 1));
      }
    }
    ++byte;
    worstDashboard = std::max(worstDashboard, legitimateCall());
    worstMetrics = std::max(worstMetrics, metricsCall());
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the attack's pace, not a wait for a result
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const auto [first, last] = std::minmax_element(answeredAfter.begin(), answeredAfter.end());
  const int threadsDuring = threadsOf(farm_.coordinator().pid());
  std::printf(
      "during a 200-connection slowloris (%.0f s): worst legitimate call %.3f s (dashboard), %.3f s "
      "(metrics); %d of 200 slow connections answered 408, %.1f-%.1f s after their first byte; threads %d "
      "-> %d\n",
      elapsed, worstDashboard, worstMetrics, answered408, *first, *last, threadsBefore, threadsDuring);
  EXPECT_GT(*first, 9.0) << "cut off before the deadline";
  EXPECT_LT(*last, 13.0) << "every slow connection is cut off at the 10 s header deadline";
  EXPECT_LT(worstDashboard, 1.0);
  EXPECT_LT(worstMetrics, 1.0);
  EXPECT_EQ(answered408, 200);
  EXPECT_LE(threadsDuring, threadsBefore + 2);
}

// 600 connections that send nothing (past the cap of 256 per port): a legitimate call still
// answers at once, because the oldest idle connection is closed to make room.
TEST_F(HostileHttp, AConnectionFloodCannotLockOutALegitimateClient) {
  std::vector<std::unique_ptr<RawConnection>> idle;
  for (int i = 0; i < 600; ++i) idle.push_back(std::make_unique<RawConnection>(dashboard_));
  double worst = 0;
  for (int i = 0; i < 5; ++i) worst = std::max(worst, legitimateCall());
  std::printf("600 idle connections: worst legitimate call %.3f s\n", worst);
  EXPECT_LT(worst, 1.0);
}

// Strict framing: a body length stated two ways, or twice differently, is 400 (a request smuggled
// past a proxy that reads the other length is not answered as if it were fine).
TEST_F(HostileHttp, AmbiguousFramingIsRefused) {
  const std::string start =
      "POST /api/jobs/job-1/priority HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
      "application/json\r\nAuthorization: Bearer " +
      token_ + "\r\n";
  for (const std::string framing :
       {"Content-Length: 4\r\nTransfer-Encoding: chunked\r\n", "Transfer-Encoding: chunked\r\nContent-Length: 4\r\n",
        "Content-Length: 4\r\nContent-Length: 5\r\n", "Content-Length: 4, 5\r\n", "Content-Length: -1\r\n",
        "Transfer-Encoding: gzip, chunked, chunked\r\n"}) {
    RawConnection connection(dashboard_);
    connection.send(start + framing + "\r\n0\r\n\r\n");
    EXPECT_EQ(connection.status(10), 400) << framing;
  }
}

// What every answer carries, the page included: no framing by another site, no sniffing, no
// Referer; and a rebinding Host is refused on a tokenless loopback dashboard.
TEST_F(HostileHttp, EveryAnswerCarriesTheSafetyHeaders) {
  for (const std::string& path :
       {std::string("/"), std::string("/app.js"), std::string("/api/jobs"), std::string("/nothing-here")}) {
    RawConnection connection(dashboard_);
    connection.send(get(path, path == "/api/jobs" ? token_ : ""));
    const std::string reply = connection.receive(10);
    for (const char* header : {"X-Frame-Options: DENY", "frame-ancestors 'none'", "X-Content-Type-Options: nosniff",
                               "Referrer-Policy: no-referrer"})
      EXPECT_NE(reply.find(header), std::string::npos) << path << " lacks " << header << "\n" << reply;
  }
}

TEST(HostileHttpTokenless, RebindingHostNamesAreRefused) {
  test::TempDir dir;
  test::FarmProcesses farm(dir);
  farm.startCoordinator({"--listen", "127.0.0.1:0", "--dashboard-listen", "127.0.0.1:0"});
  const int port = test::portOf(farm.dashboardAddress());
  for (const char* host : {"127.attacker.example", "127.0.0.1.nip.io", "127.0.0.1.nip.io:80", "[::1]evil",
                           "localhost.attacker.example", "attacker.example"}) {
    RawConnection connection(port);
    connection.send(get("/api/jobs", "", host));
    EXPECT_EQ(connection.status(10), 403) << host;
    RawConnection action(port);
    action.send("POST /api/jobs/job-1/cancel HTTP/1.1\r\nHost: " + std::string(host) +
                "\r\nContent-Type: application/json\r\nContent-Length: 2\r\nConnection: close\r\n\r\n{}");
    EXPECT_EQ(action.status(10), 403) << host;
  }
  for (const char* host : {"127.0.0.1", "localhost:8080", "[::1]:1"}) {
    RawConnection connection(port);
    connection.send(get("/api/jobs", "", host));
    EXPECT_EQ(connection.status(10), 200) << host;
  }
}

}  // namespace
}  // namespace lensfarm
