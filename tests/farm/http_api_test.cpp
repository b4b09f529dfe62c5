// The HTTP/JSON API and the webhooks (docs/api.md) of a real coordinator with real workers:
//  - a client written from the OpenAPI document alone (tests/farm/openapi_client.py: Python's
//    urllib and json, nothing of the project's) drives every operation, checks every answer
//    against the document's schemas, and downloads an image that is `lensfarm render`'s, bit for bit;
//  - the document in docs/ is the one the coordinator serves;
//  - a webhook receiver (cpp-httplib's server) that fails the first delivery still gets every
//    event, in order, each signed (HMAC-SHA256 checked here with OpenSSL, independently);
//  - the CLI's `update` and `events`; bad flags refused naming them.
#include <gtest/gtest.h>
#include <httplib.h>
#include <openssl/hmac.h>

#include <atomic>
#include <csignal>
#include <mutex>
#include <thread>

#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

class HttpApi : public test::FarmFixture {
 protected:
  fs::path token(const std::string& name, const std::string& secret) {
    const fs::path file = dir_.write(name + ".token", secret + "\n");
    fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
    return file;
  }
  // A coordinator with the dashboard's listener (which serves /api/v1); its dashboard address.
  std::string startWithApi(std::vector<std::string> extra, std::string* grpcAddress) {
    const fs::path dport = dir_ / "dashboard-port";
    extra.insert(extra.end(), {"--dashboard-listen", "127.0.0.1:0", "--dashboard-port-file", dport.string()});
    *grpcAddress = startCoordinator("127.0.0.1:0", extra);
    EXPECT_TRUE(test::waitFor([&] { return fs::exists(dport) && fs::file_size(dport) > 0; }, 30));
    std::string address = test::readFile(dport);
    address.erase(address.find_last_not_of("\n") + 1);
    return address;
  }
};

TEST_F(HttpApi, AClientWrittenFromTheOpenApiDocumentAloneDrivesEveryOperation) {
  const fs::path admin = token("admin", "an-api-clients-token-42");
  std::string grpc;
  const std::string http = startWithApi({"--client-token-file", admin.string()}, &grpc);
  startWorker(grpc, "w1");
  startWorker(grpc, "w2");
  const fs::path scene = writeScene(24, 16, 4);
  const fs::path out = dir_ / "from-http.exr";
  const auto r =
      test::runProcess({"/usr/bin/python3", (test::sourceDir() / "tests/farm/openapi_client.py").string(), "--base",
                        "http://" + http, "--token-file", admin.string(), "--document",
                        (test::sourceDir() / "docs/api/openapi.json").string(), "--scene", scene.string(), "--asset",
                        "meshes/cornell-box.obj=" + (dir_ / "meshes/cornell-box.obj").string(), "--out", out.string()},
                       600);
  EXPECT_EQ(r.exitCode, 0) << r.out << r.err << coordinator_->log();
  EXPECT_TRUE(test::contains(r.out, "all checks passed")) << r.out;
  // The image that came over HTTP is the one-process render's, bit for bit.
  ImageMetadata httpMeta, localMeta;
  const Image fromHttp = readExr(out, &httpMeta);
  const Image local = renderInProcess(scene, &localMeta);
  EXPECT_TRUE(fromHttp.rgb == local.rgb);
}

TEST_F(HttpApi, TheDocumentInDocsIsTheOneTheCoordinatorServes) {
  const auto r = test::runProcess({test::coordinatorPath().string(), "--print-openapi"}, 60);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, test::readFile(test::sourceDir() / "docs/api/openapi.json"))
      << "docs/api/openapi.json is stale: lensfarm-coordinator --print-openapi > docs/api/openapi.json";
}

TEST_F(HttpApi, TheCliUpdatesAJobAndPrintsTheFarmsEvents) {
  const std::string address = startCoordinator();
  const fs::path scene = writeScene(16, 16, 4);
  const std::string job = submit(address, scene, {"--paused"});
  const auto updated = cli({"update", job, "--priority", "3", "--max-workers", "1", "--coordinator", address});
  EXPECT_EQ(updated.exitCode, 0) << updated.err;
  EXPECT_TRUE(test::contains(updated.out, job + " queued, priority 3, max workers 1")) << updated.out;
  const auto zero = cli({"update", job, "--max-workers", "0", "--coordinator", address});
  EXPECT_EQ(zero.exitCode, 2) << zero.out << zero.err;
  EXPECT_TRUE(test::contains(zero.err, "max")) << zero.err;
  const auto nothing = cli({"update", job, "--coordinator", address});
  EXPECT_EQ(nothing.exitCode, 2);
  const auto unknown = cli({"update", "job-99", "--priority", "1", "--coordinator", address});
  EXPECT_EQ(unknown.exitCode, 4) << unknown.err;
  const auto cancelled = cli({"cancel", job, "--coordinator", address});
  ASSERT_EQ(cancelled.exitCode, 0);
  const auto events = cli({"events", "--job", job, "--coordinator", address});
  EXPECT_EQ(events.exitCode, 0) << events.err;
  EXPECT_TRUE(std::regex_search(events.out, std::regex("1 [-0-9: ]+ job.submitted +" + job))) << events.out;
  EXPECT_TRUE(std::regex_search(events.out, std::regex("2 [-0-9: ]+ job.cancelled +" + job))) << events.out;
  const auto after = cli({"events", "--after", "1", "--coordinator", address});
  EXPECT_FALSE(test::contains(after.out, "job.submitted")) << after.out;
}

// A webhook receiver: answers 500 to the first delivery (or to every one while refusing), 200 to
// the rest, and keeps them all.
class Receiver {
 public:
  struct Delivery {
    std::string event, id, signature, body;
    int answered = 0;
  };
  std::atomic<bool> refusing{false};
  Receiver() {
    server_.Post("/hook", [this](const httplib::Request& request, httplib::Response& response) {
      std::lock_guard lock(mutex_);
      Delivery d{request.get_header_value("X-Lensfarm-Event"), request.get_header_value("X-Lensfarm-Delivery"),
                 request.get_header_value("X-Lensfarm-Signature"), request.body};
      d.answered = deliveries_.empty() || refusing ? 500 : 200;
      response.status = d.answered;
      deliveries_.push_back(d);
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
  }
  ~Receiver() {
    server_.stop();
    thread_.join();
  }
  int port() const { return port_; }
  std::vector<Delivery> deliveries() {
    std::lock_guard lock(mutex_);
    return deliveries_;
  }

 private:
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
  std::mutex mutex_;
  std::vector<Delivery> deliveries_;
};

// "t=UNIX,v1=HEX" checked against HMAC-SHA256(secret, "UNIX." + body), computed here.
bool signatureHolds(const std::string& secret, const std::string& header, const std::string& body) {
  std::smatch m;
  if (!std::regex_match(header, m, std::regex("t=([0-9]+),v1=([0-9a-f]{64})"))) return false;
  const std::string message = m[1].str() + "." + body;
  unsigned char mac[32];
  unsigned length = 0;
  HMAC(EVP_sha256(), secret.data(), int(secret.size()), reinterpret_cast<const unsigned char*>(message.data()),
       message.size(), mac, &length);
  char hex[65];
  for (int i = 0; i < 32; ++i) std::snprintf(hex + 2 * i, 3, "%02x", mac[i]);
  return m[2].str() == std::string(hex, 64);
}

TEST_F(HttpApi, AWebhookReceiverThatFailsTheFirstDeliveryGetsEveryEventSignedAndInOrder) {
  Receiver receiver;
  const std::string secret = "a-webhook-signing-secret-7";
  const fs::path secretFile = token("webhook", secret);
  const std::string address =
      startCoordinator("127.0.0.1:0", {"--webhook", "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook",
                                       "--webhook-secret-file", secretFile.string(), "--webhook-events",
                                       "job.submitted,job.started,job.done,worker.joined"});
  startWorker(address, "w1");
  const std::string job = submit(address, writeScene(16, 16, 4));
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  ASSERT_TRUE(test::waitFor(
      [&] {
        for (const auto& d : receiver.deliveries())
          if (d.event == "job.done" && d.answered == 200) return true;
        return false;
      },
      60))
      << coordinator_->log();
  const auto deliveries = receiver.deliveries();
  // The first was refused and delivered again, with the same id and body.
  ASSERT_GE(deliveries.size(), 4u);
  EXPECT_EQ(deliveries[0].answered, 500);
  EXPECT_EQ(deliveries[1].id, deliveries[0].id);
  EXPECT_EQ(deliveries[1].body, deliveries[0].body);
  EXPECT_EQ(deliveries[1].answered, 200);
  // Every one signed; in order; only the types asked for; each delivered (200) once.
  std::vector<std::string> types;
  uint64_t last = 0;
  for (const auto& d : deliveries) {
    EXPECT_TRUE(signatureHolds(secret, d.signature, d.body)) << d.signature << " " << d.body;
    EXPECT_GE(std::stoull(d.id), last);
    last = std::stoull(d.id);
    const auto body = nlohmann::json::parse(d.body);
    EXPECT_EQ(body["type"], d.event);
    EXPECT_EQ(body["sequence"], d.id) << "the delivery id is the event's sequence";
    if (d.answered == 200) types.push_back(d.event);
  }
  const std::vector<std::string> jobTypes = [&] {
    std::vector<std::string> t;
    for (const auto& x : types)
      if (x != "worker.joined") t.push_back(x);
    return t;
  }();
  EXPECT_EQ(jobTypes, (std::vector<std::string>{"job.submitted", "job.started", "job.done"}));
  EXPECT_EQ(std::count(types.begin(), types.end(), "worker.joined"), 1);
  // A forged signature (another secret) does not hold: the check above discriminates.
  EXPECT_FALSE(signatureHolds("another-secret", deliveries[1].signature, deliveries[1].body));
  // Nothing secret in the log.
  EXPECT_FALSE(test::contains(coordinator_->log(), secret));
}

// With a state dir the events and each URL's progress are kept: a delivery the receiver refused
// until the coordinator stopped is made after it restarts, with the same id; one already made is
// not made again; the numbering goes on.
TEST_F(HttpApi, AWebhookDeliveryPendingWhenTheCoordinatorStopsIsMadeAfterItRestarts) {
  Receiver receiver;
  receiver.refusing = true;
  const fs::path secretFile = token("webhook", "a-webhook-signing-secret-7");
  const std::vector<std::string> flags = {"--state-dir",
                                          (dir_ / "state").string(),
                                          "--webhook",
                                          "http://127.0.0.1:" + std::to_string(receiver.port()) + "/hook",
                                          "--webhook-secret-file",
                                          secretFile.string(),
                                          "--webhook-events",
                                          "job.submitted",
                                          "--webhook-attempts",
                                          "1000"};
  const auto deliveredOf = [&](const std::string& id) {
    int n = 0;
    for (const auto& d : receiver.deliveries()) n += d.id == id && d.answered == 200;
    return n;
  };
  std::string address = startCoordinator("127.0.0.1:0", flags);
  const std::string first = submit(address, writeScene(16, 16, 4), {"--paused"});
  ASSERT_TRUE(test::waitFor([&] { return !receiver.deliveries().empty(); }, 30)) << coordinator_->log();
  const std::string id = receiver.deliveries().front().id;
  coordinator_->signal(SIGTERM);
  ASSERT_EQ(coordinator_->wait(30), 0) << coordinator_->log();
  EXPECT_EQ(deliveredOf(id), 0);

  receiver.refusing = false;
  address = startCoordinator("127.0.0.1:0", flags);
  ASSERT_TRUE(test::waitFor([&] { return deliveredOf(id) == 1; }, 30)) << coordinator_->log();
  const auto body = nlohmann::json::parse(receiver.deliveries().back().body);
  EXPECT_EQ(body["job_id"], first) << "the same event, after the restart";
  coordinator_->signal(SIGTERM);
  ASSERT_EQ(coordinator_->wait(30), 0);

  // Once more: the delivered event is not delivered again (deliveries are in order, so the next
  // job's arriving first shows it); the numbering goes on.
  address = startCoordinator("127.0.0.1:0", flags);
  const std::string second = submit(address, writeScene(16, 16, 4), {"--paused"});
  std::string secondId;
  ASSERT_TRUE(test::waitFor(
      [&] {
        for (const auto& d : receiver.deliveries())
          if (d.answered == 200 && nlohmann::json::parse(d.body)["job_id"] == second) secondId = d.id;
        return !secondId.empty();
      },
      30));
  EXPECT_EQ(deliveredOf(id), 1) << "delivered once";
  EXPECT_GT(std::stoull(secondId), std::stoull(id));
}

TEST_F(HttpApi, BadWebhookFlagsAreRefusedNamingThem) {
  const fs::path secretFile = token("webhook", "a-webhook-signing-secret-7");
  const auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {test::coordinatorPath().string(), "--listen", "127.0.0.1:0"});
    return test::runProcess(args, 60);
  };
  const auto scheme = run({"--webhook", "ftp://example.com/x", "--webhook-secret-file", secretFile.string()});
  EXPECT_EQ(scheme.exitCode, 2);
  EXPECT_TRUE(test::contains(scheme.err + scheme.out, "--webhook: \"ftp://example.com/x\"")) << scheme.err;
  const auto type = run({"--webhook", "http://127.0.0.1:9/x", "--webhook-secret-file", secretFile.string(),
                         "--webhook-events", "job.done,job.exploded"});
  EXPECT_EQ(type.exitCode, 2);
  EXPECT_TRUE(test::contains(type.err + type.out, "--webhook-events: \"job.exploded\"")) << type.err;
  const auto unsigned_ = run({"--webhook", "http://127.0.0.1:9/x"});
  EXPECT_EQ(unsigned_.exitCode, 2);
  EXPECT_TRUE(test::contains(unsigned_.err + unsigned_.out, "--webhook-secret-file")) << unsigned_.err;
}

}  // namespace
}  // namespace lensfarm
