// Hostile clients against a real coordinator's gRPC services, each bound asserted and printed:
// a flood of WatchJob streams from the viewer token (threads stay flat, the role's cap holds,
// other roles and calls are served), a flood of refused calls (the log stays short), and a
// Sybil worker: one credential registered again and again to fail a job (it cannot).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <fstream>

#include "common/farm/farm_types.h"
#include "common/util/version.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "lensfarm/v1/worker_service.grpc.pb.h"
#include "tests/deploy_support.h"
#include "tests/support/stream_flood.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

int threadsOf(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("Threads:", 0) == 0) return std::atoi(line.c_str() + 8);
  return -1;
}

class HostileGrpc : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto secret = [&](const std::string& name, const std::string& token) {
      const fs::path file = dir_.write(name, token + "\n");
      fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
      return file.string();
    };
    address_ = farm_.startCoordinator(
        {"--listen", "127.0.0.1:0", "--client-token-file", secret("client.token", client_), "--viewer-token-file",
         secret("viewer.token", viewer_), "--worker-token-file", secret("worker.token", shared_),
         "--worker-credentials", secret("workers.credentials", "sybil " + sybil_ + "\nhonest " + honest_ + "\n")});
    job_ = farm_.submit({test::writeSeedScene(dir_, 16, 1 << 20, 8).string(), "--coordinator", address_, "--token-file",
                         (dir_ / "client.token").string()});
  }

  std::unique_ptr<v1::ClientService::Stub> stub() {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // a connection of its own
    return v1::ClientService::NewStub(grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), args));
  }

  test::TempDir dir_;
  test::FarmProcesses farm_{dir_};
  const std::string client_ = "client-token-of-the-hostile-grpc-test",
                    viewer_ = "viewer-token-of-the-hostile-grpc-test",
                    shared_ = "worker-token-of-the-hostile-grpc-test", sybil_ = "sybil-credential-of-the-grpc-test",
                    honest_ = "honest-credential-of-the-grpc-test";
  std::string address_, job_;
};

// 2,000 viewer WatchJob streams on 20 connections: the coordinator's threads stay within 50 of
// idle, the viewer's cap (1,024 streams) holds (the rest are RESOURCE_EXHAUSTED, naming it), and
// while they are open the client token still watches and a GetJob answers.
TEST_F(HostileGrpc, AWatchJobFloodCostsNoThreadsAndMeetsTheRolesCap) {
  const int pid = farm_.coordinator().pid();
  const int idle = threadsOf(pid);
  std::vector<std::unique_ptr<v1::ClientService::Stub>> stubs;
  for (int i = 0; i < 20; ++i) stubs.push_back(stub());
  v1::WatchJobRequest request;
  request.set_job_id(job_);
  test::StreamFlood<v1::JobStatus> flood(
      2000, [&](size_t k, grpc::ClientContext& context, grpc::CompletionQueue& queue) {
        context.AddMetadata("authorization", "Bearer " + viewer_);
        return stubs[k % stubs.size()]->PrepareAsyncWatchJob(&context, request, &queue);
      });
  const auto counts = flood.settle(std::chrono::seconds(120));
  const int flooded = threadsOf(pid);

  // Meanwhile the client's own watch and a plain call are served.
  auto clientStub = stub();
  grpc::ClientContext clientContext;
  clientContext.AddMetadata("authorization", "Bearer " + client_);
  auto reader = clientStub->WatchJob(&clientContext, request);
  v1::JobStatus first;
  EXPECT_TRUE(reader->Read(&first)) << "the client token's own streams have their own cap";
  clientContext.TryCancel();
  grpc::ClientContext getContext;
  getContext.AddMetadata("authorization", "Bearer " + viewer_);
  getContext.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  v1::GetJobRequest get;
  get.set_job_id(job_);
  v1::JobStatus got;
  EXPECT_TRUE(clientStub->GetJob(&getContext, get, &got).ok());

  std::printf(
      "2000 viewer WatchJob streams: %zu streaming, %zu refused RESOURCE_EXHAUSTED, %zu other; coordinator "
      "threads %d idle -> %d\n",
      counts.held, counts.refused, counts.other, idle, flooded);
  EXPECT_EQ(counts.pending, 0u);
  EXPECT_EQ(counts.held, 1024u);
  EXPECT_EQ(counts.refused, 2000u - 1024u);
  EXPECT_NE(counts.refusal.find("the viewer token already has 1024 streams open"), std::string::npos) << counts.refusal;
  EXPECT_LT(flooded - idle, 50);

  flood.cancel();
  // The streams end and their slots come back: a new viewer watch is served.
  ASSERT_TRUE(test::waitFor(
      [&] {
        grpc::ClientContext again;
        again.AddMetadata("authorization", "Bearer " + viewer_);
        auto r = clientStub->WatchJob(&again, request);
        v1::JobStatus status;
        const bool read = r->Read(&status);
        again.TryCancel();
        return read;
      },
      30));
}

// 5,000 refused calls (wrong token) in a burst: the coordinator's log holds a few lines that say
// how many more there were, not 5,000.
TEST_F(HostileGrpc, RefusedCallsAreLoggedAtABoundedRate) {
  auto s = stub();
  for (int i = 0; i < 5000; ++i) {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer not-the-token");
    v1::ListJobsRequest request;
    v1::ListJobsResponse response;
    ASSERT_EQ(s->ListJobs(&context, request, &response).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
  std::string log = farm_.coordinator().log();
  size_t lines = 0;
  for (size_t at = log.find("refused ListJobs"); at != std::string::npos; at = log.find("refused ListJobs", at + 1))
    ++lines;
  std::printf("5000 refused calls: %zu log lines\n", lines);
  EXPECT_GE(lines, 1u);
  EXPECT_LE(lines, 20u);
}

// A worker registration, made by hand as a hostile client would.
struct Registration {
  std::string id, session;
  grpc::Status status;
};

Registration registerAs(v1::WorkerService::Stub& stub, const std::string& token, const std::string& name) {
  grpc::ClientContext context;
  context.AddMetadata("authorization", "Bearer " + token);
  v1::RegisterRequest request;
  request.set_name(name);
  request.set_threads(1);
  request.set_protocol_version(kProtocolVersion);
  request.set_renderer_version(kRendererVersion);
  v1::RegisterResponse response;
  Registration r;
  r.status = stub.Register(&context, request, &response);
  r.id = response.worker_id();
  r.session = response.session();
  return r;
}

// Leases a unit and reports it failed: false when no unit was leased.
bool leaseAndFail(v1::WorkerService::Stub& stub, const std::string& token, const Registration& r) {
  grpc::ClientContext leaseContext;
  leaseContext.AddMetadata("authorization", "Bearer " + token);
  v1::LeaseWorkRequest lease;
  lease.set_worker_id(r.id);
  lease.set_session(r.session);
  lease.set_wait_ms(2000);
  v1::LeaseWorkResponse granted;
  const grpc::Status leased = stub.LeaseWork(&leaseContext, lease, &granted);
  EXPECT_TRUE(leased.ok()) << leased.error_message();
  if (!granted.has_lease()) return false;
  grpc::ClientContext failContext;
  failContext.AddMetadata("authorization", "Bearer " + token);
  v1::ReportFailureRequest failure;
  failure.set_worker_id(r.id);
  failure.set_session(r.session);
  failure.set_lease_id(granted.lease().lease_id());
  failure.set_job_id(granted.lease().job_id());
  failure.set_error("forged failure");
  v1::ReportFailureResponse none;
  const grpc::Status reported = stub.ReportFailure(&failContext, failure, &none);
  EXPECT_TRUE(reported.ok()) << reported.error_message();
  return true;
}

// The Sybil attack of one worker token: three registrations lease the same unit and report it
// failed three times. With a per-machine credential they are one machine: one id, each new
// registration superseding the last (whose session is refused, naming the credential), the
// credential blocklisted after its 3 failures, the job running on for the honest worker. The same
// attack with the shared token — a trusted pool by design (docs/farm.md "Worker identity") —
// fails the job: the difference the credential makes.
TEST_F(HostileGrpc, ThreeRegistrationsOfOneCredentialCannotFailAJob) {
  auto workers = v1::WorkerService::NewStub(grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
  const Registration honest = registerAs(*workers, honest_, "honest");
  ASSERT_TRUE(honest.status.ok()) << honest.status.error_message();
  std::vector<Registration> sybils;
  for (int k = 0; k < 3; ++k) {
    sybils.push_back(registerAs(*workers, sybil_, "sybil-" + std::to_string(k)));
    ASSERT_TRUE(sybils.back().status.ok()) << sybils.back().status.error_message();
    EXPECT_TRUE(leaseAndFail(*workers, sybil_, sybils.back())) << "registration " << k << " is leased a unit";
  }
  EXPECT_EQ(sybils[0].id, sybils[2].id) << "one credential, one worker id";
  {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer " + sybil_);
    v1::HeartbeatRequest beat;
    beat.set_worker_id(sybils[0].id);
    beat.set_session(sybils[0].session);
    v1::HeartbeatResponse none;
    const grpc::Status superseded = workers->Heartbeat(&context, beat, &none);
    EXPECT_EQ(superseded.error_code(), grpc::StatusCode::PERMISSION_DENIED);
    EXPECT_NE(superseded.error_message().find("credential sybil"), std::string::npos) << superseded.error_message();
  }
  EXPECT_FALSE(leaseAndFail(*workers, sybil_, registerAs(*workers, sybil_, "sybil-3")))
      << "the credential failed the job 3 times: it is not leased it again";
  const auto client = stub();
  const auto jobState = [&] {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer " + client_);
    v1::GetJobRequest request;
    request.set_job_id(job_);
    v1::JobStatus status;
    EXPECT_TRUE(client->GetJob(&context, request, &status).ok());
    return status.state();
  };
  EXPECT_EQ(jobState(), v1::JOB_STATE_RUNNING) << "three registrations of one credential failed the job";
  {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer " + client_);
    v1::ListWorkersResponse list;
    ASSERT_TRUE(client->ListWorkers(&context, v1::ListWorkersRequest(), &list).ok());
    int sybilLines = 0;
    for (const auto& w : list.workers())
      if (w.credential() == "sybil") {
        ++sybilLines;
        EXPECT_EQ(w.registrations(), 4u);
        EXPECT_EQ(w.failures(), 3u);
      }
    EXPECT_EQ(sybilLines, 1) << "one line per machine in `lensfarm workers`";
  }
  std::printf("[bound] 4 registrations of one credential: 1 worker id, 3 failures counted once, job %s\n",
              jobState() == v1::JOB_STATE_RUNNING ? "running" : "ended");
  for (int k = 0; k < 3; ++k)
    leaseAndFail(*workers, shared_, registerAs(*workers, shared_, "pool-" + std::to_string(k)));
  EXPECT_EQ(jobState(), v1::JOB_STATE_FAILED) << "the shared token's registrations are separate workers";
}

}  // namespace
}  // namespace lensfarm
