// What the farm commands print of the cross-worker audit (docs/farm.md "Audit"): the real
// `lensfarm` binary asks a stand-in ClientService in this process, which answers with a
// hand-filled JobInfo and WorkerViews through the coordinator's own translation (service.h), so a
// field lost between the coordinator and the screen fails here. And the coordinator's two audit
// flags refuse what is not a fraction or a tolerance.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "coordinator/rpc/service.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "tests/coordinator/audit_views.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

using test::contains;

// Answers GetJob and ListWorkers from hand-filled values; every other call is UNIMPLEMENTED.
class StandInService final : public v1::ClientService::Service {
 public:
  JobInfo job;
  std::vector<WorkerView> workers;

  grpc::Status GetJob(grpc::ServerContext*, const v1::GetJobRequest* request, v1::JobStatus* response) override {
    if (request->job_id() != job.id) return grpc::Status(grpc::StatusCode::NOT_FOUND, "no such job");
    *response = toProto(job);
    return grpc::Status::OK;
  }
  grpc::Status ListWorkers(grpc::ServerContext*, const v1::ListWorkersRequest*,
                           v1::ListWorkersResponse* response) override {
    for (const WorkerView& w : workers) *response->add_workers() = toProto(w);
    return grpc::Status::OK;
  }
};

class CliAuditOutput : public ::testing::Test {
 protected:
  void SetUp() override {
    service_.job = test::auditedJob();
    service_.workers = test::auditedWorkers();
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service_);
    server_ = builder.BuildAndStart();
    ASSERT_TRUE(server_ && port > 0);
    address_ = "127.0.0.1:" + std::to_string(port);
  }
  void TearDown() override {
    if (server_) server_->Shutdown();
  }
  // `lensfarm ARGS --coordinator ADDRESS` in UTC, so the events' local times are known.
  test::ProcessResult cli(std::vector<std::string> args) {
    args.insert(args.begin(), {"/usr/bin/env", "TZ=UTC0", test::cliPath().string()});
    args.insert(args.end(), {"--coordinator", address_});
    return test::runProcess(args, 60);
  }
  // The line of `text` that starts with `prefix`, or "".
  static std::string lineStarting(const std::string& text, const std::string& prefix) {
    for (const std::string& line : test::lines(text))
      if (line.rfind(prefix, 0) == 0) return line;
    return "";
  }

  StandInService service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

TEST_F(CliAuditOutput, StatusShowsTheAuditCountsAndTheEventsInLocalTime) {
  const auto r = cli({"status", "job-7"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(lineStarting(r.out, "audit:"), "audit:      12 passed, 1 failed, 2 pending; 40 units rendered again")
      << r.out;
  const std::vector<std::string> lines = test::lines(r.out);
  const auto events = std::find(lines.begin(), lines.end(), "events:");
  ASSERT_NE(events, lines.end()) << r.out;
  ASSERT_GE(lines.end() - events, 3) << r.out;
  EXPECT_EQ(events[1], "  2026-11-18 11:06:43  audit of unit 12 failed: w2 and w4 agree, w3 differs");
  EXPECT_EQ(events[2], "  2026-11-18 11:06:44  worker w3 quarantined; its 40 counted units queued again");
  EXPECT_LT(r.out.find("audit:"), r.out.find("effect:")) << "the counts among the job's figures, the events last";
  EXPECT_LT(r.out.find("effect:"), r.out.find("events:"));
}

TEST_F(CliAuditOutput, StatusSaysNothingOfTheAuditWhenItHasNothingToSay) {
  service_.job = JobInfo{};
  service_.job.id = "job-1";
  service_.job.sceneName = "plain.json";
  const auto r = cli({"status", "job-1"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_FALSE(contains(r.out, "audit:")) << r.out;
  EXPECT_FALSE(contains(r.out, "events:")) << r.out;
  // Any one count shows the line.
  service_.job.unitsRerendered = 3;
  EXPECT_EQ(lineStarting(cli({"status", "job-1"}).out, "audit:"),
            "audit:      0 passed, 0 failed, 0 pending; 3 units rendered again");
}

TEST_F(CliAuditOutput, WorkersShowQuarantineFirstAndAuditsPassedBesideFailures) {
  const auto r = cli({"workers"});
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string w1 = lineStarting(r.out, "w1 "), w3 = lineStarting(r.out, "w3 ");
  ASSERT_FALSE(w1.empty() || w3.empty()) << r.out;
  EXPECT_TRUE(contains(
      w3, std::string("  quarantined: ") + test::kQuarantineReason + "; idle; 3 of its units confirmed by audit"));
  EXPECT_TRUE(contains(w1, "  rendering; 2 failed unit(s); 5 of its units confirmed by audit; blocklisted for job-2"));
  EXPECT_FALSE(contains(w1, "quarantined")) << w1;
}

// ---- the coordinator's flags ----------------------------------------------------------------

TEST(CoordinatorFlags, RefuseWhatIsNotAFiniteNumberInRange) {
  struct Bad {
    std::vector<std::string> args;
    std::string mustName;
  };
  const std::vector<Bad> cases = {
      {{"--audit-fraction", "1.5"}, "--audit-fraction"},
      {{"--audit-fraction", "-0.1"}, "--audit-fraction"},
      {{"--audit-fraction", "nan"}, "--audit-fraction"},
      {{"--audit-fraction", "half"}, "--audit-fraction"},
      {{"--audit-tolerance", "-1e-6"}, "--audit-tolerance"},
      {{"--audit-tolerance", "inf"}, "--audit-tolerance"},
      {{"--audit-tolerance", "nan"}, "--audit-tolerance"},
      {{"LENSFARM_AUDIT_FRACTION=2"}, "--audit-fraction"},
      {{"LENSFARM_AUDIT_TOLERANCE=-1"}, "--audit-tolerance"},
      // Every number flag of the coordinator refuses what is not a finite number (CLI::Range
      // alone lets "nan" through).
      {{"--lease-timeout", "nan"}, "--lease-timeout"},
      {{"--heartbeat-interval", "inf"}, "--heartbeat-interval"},
      {{"--max-lease", "nan"}, "--max-lease"},
      {{"--checkpoint-every", "nan"}, "--checkpoint-every"},
  };
  for (const Bad& c : cases) {
    SCOPED_TRACE(c.args[0] + (c.args.size() > 1 ? " " + c.args[1] : ""));
    std::vector<std::string> argv = {"/usr/bin/env"};
    if (c.args.size() == 1) argv.push_back(c.args[0]);  // a variable
    argv.insert(argv.end(), {test::coordinatorPath().string(), "--listen", "127.0.0.1:0"});
    if (c.args.size() == 2) argv.insert(argv.end(), c.args.begin(), c.args.end());
    const auto r = test::runProcess(argv, 30);
    EXPECT_EQ(r.exitCode, test::kBadInput) << r.err;
    EXPECT_TRUE(contains(r.err, c.mustName));
  }
  const auto help = test::runProcess({test::coordinatorPath().string(), "--help"}, 30);
  EXPECT_TRUE(contains(help.out, "--audit-fraction"));
  EXPECT_TRUE(contains(help.out, "LENSFARM_AUDIT_TOLERANCE"));
}

TEST(WorkerFlags, RefuseABackoffThatIsNotAFiniteNumber) {
  for (const char* bad : {"nan", "inf", "0.01"}) {
    const auto r =
        test::runProcess({test::workerPath().string(), "--coordinator", "127.0.0.1:1", "--max-backoff", bad}, 30);
    EXPECT_EQ(r.exitCode, test::kBadInput) << bad << ": " << r.err;
    EXPECT_TRUE(contains(r.err, "--max-backoff")) << r.err;
  }
}

TEST(CoordinatorFlags, AcceptTheirRangesEnds) {
  test::TempDir dir;
  for (const std::vector<std::string>& flags :
       {std::vector<std::string>{"--audit-fraction", "0", "--audit-tolerance", "0"},
        std::vector<std::string>{"--audit-fraction", "1", "--audit-tolerance", "1e300"}}) {
    SCOPED_TRACE(flags[1] + " " + flags[3]);
    const auto portFile = dir / ("port-" + flags[1]);
    std::vector<std::string> argv = {test::coordinatorPath().string(), "--listen", "127.0.0.1:0", "--port-file",
                                     portFile.string()};
    argv.insert(argv.end(), flags.begin(), flags.end());
    test::ChildProcess coordinator(argv, dir / ("coordinator-" + flags[1]));
    EXPECT_TRUE(test::waitFor([&] { return !test::readFile(portFile).empty(); }, 30)) << coordinator.log();
  }
}

}  // namespace
}  // namespace lensfarm
