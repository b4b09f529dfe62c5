// A worker that does not behave, over real gRPC against a real coordinator process (an
// outside check, as a foreign client generated from proto/ would drive it): it may only harm its
// own leases. Every forged call gets its status and changes nothing; the job then finishes with
// an honest worker process and its image equals the in-process render bit for bit.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "common/farm/farm_types.h"
#include "common/util/hash.h"
#include "common/util/version.h"
#include "lensfarm/v1/worker_service.grpc.pb.h"
#include "tests/farm/farm_fixture.h"

namespace lensfarm {
namespace {

namespace v1 = lensfarm::v1;

class RogueWorker : public test::FarmFixture {
 protected:
  struct Identity {
    std::string id, session;
  };

  // Names `who` in a request: its id and session.
  template <typename Request>
  static void identify(Request& request, const Identity& who) {
    request.set_worker_id(who.id);
    request.set_session(who.session);
  }

  void connect(const std::string& address) {
    stub_ = v1::WorkerService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  }
  std::unique_ptr<grpc::ClientContext> context() {
    auto c = std::make_unique<grpc::ClientContext>();
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
    return c;
  }
  Identity registerAs(const std::string& name) {
    v1::RegisterRequest request;
    request.set_name(name);
    request.set_threads(1);
    request.set_protocol_version(kProtocolVersion);
    request.set_renderer_version(kRendererVersion);
    v1::RegisterResponse response;
    const grpc::Status s = stub_->Register(context().get(), request, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(response.session().size(), 64u) << "256 random bits, in hex";
    return {response.worker_id(), response.session()};
  }
  grpc::Status heartbeat(const Identity& who, const std::vector<uint64_t>& leases, v1::HeartbeatResponse* out) {
    v1::HeartbeatRequest request;
    identify(request, who);
    for (uint64_t id : leases) request.add_lease_ids(id);
    return stub_->Heartbeat(context().get(), request, out);
  }
  v1::Lease lease(const Identity& who) {
    v1::LeaseWorkRequest request;
    identify(request, who);
    request.set_wait_ms(5000);
    v1::LeaseWorkResponse response;
    const grpc::Status s = stub_->LeaseWork(context().get(), request, &response);
    EXPECT_TRUE(s.ok() && response.has_lease()) << s.error_message();
    return response.lease();
  }
  // An upload under `lease` as `who`, every sum `value`, with `paths` paths (default: the
  // unit's, 1 per pixel and sample).
  grpc::Status upload(const Identity& who, const v1::Lease& lease, int size, double value,
                      std::optional<uint64_t> paths = std::nullopt) {
    v1::UploadResultResponse response;
    auto ctx = context();
    auto writer = stub_->UploadResult(ctx.get(), &response);
    v1::UploadResultRequest message;
    auto* h = message.mutable_header();
    identify(*h, who);
    h->set_lease_id(lease.lease_id());
    h->set_job_id(lease.job_id());
    h->set_unit_index(lease.unit_index());
    h->set_width(uint32_t(size));
    h->set_height(uint32_t(size));
    h->mutable_stats()->set_paths(paths ? *paths : uint64_t(size) * size * lease.sample_count());
    h->mutable_stats()->set_rays(h->stats().paths() * 3);
    const std::vector<double> sums(size_t(size) * size * 3, value);
    message.set_sums(reinterpret_cast<const char*>(sums.data()), sums.size() * sizeof(double));
    writer->Write(message);
    writer->WritesDone();
    return writer->Finish();
  }
  grpc::Status reportFailure(const Identity& who, uint64_t leaseId, const std::string& job) {
    v1::ReportFailureRequest request;
    identify(request, who);
    request.set_lease_id(leaseId);
    request.set_job_id(job);
    request.set_error("forged");
    v1::ReportFailureResponse response;
    return stub_->ReportFailure(context().get(), request, &response);
  }
  grpc::Status jobSpec(const Identity& who, const std::string& job) {
    v1::GetJobSpecRequest request;
    request.set_job_id(job);
    identify(request, who);
    v1::JobSpec response;
    return stub_->GetJobSpec(context().get(), request, &response);
  }
  grpc::Status fetchAsset(const Identity& who, const std::string& sha) {
    v1::FetchAssetRequest request;
    request.set_sha256(sha);
    identify(request, who);
    auto ctx = context();
    auto reader = stub_->FetchAsset(ctx.get(), request);
    v1::FileChunk chunk;
    while (reader->Read(&chunk)) {
    }
    return reader->Finish();
  }

  std::unique_ptr<v1::WorkerService::Stub> stub_;
};

#define EXPECT_STATUS(call, code, part)                                                          \
  do {                                                                                           \
    const grpc::Status status_ = (call);                                                         \
    EXPECT_EQ(status_.error_code(), grpc::StatusCode::code) << status_.error_message();          \
    EXPECT_NE(status_.error_message().find(part), std::string::npos) << status_.error_message(); \
  } while (0)

TEST_F(RogueWorker, CanHarmOnlyItsOwnLeasesAndTheImageKeepsItsBits) {
  const int size = 16;
  const std::filesystem::path scene = writeScene(size, 8, 1);  // 8 units of 1 sample
  const std::string address = startCoordinator("127.0.0.1:0", {"--lease-timeout", "4"});
  connect(address);
  const std::string job = submit(address, scene);
  const Identity rogue = registerAs("rogue"), honest = registerAs("honest");
  const v1::Lease mine = lease(rogue), theirs = lease(honest);
  ASSERT_NE(mine.unit_index(), theirs.unit_index());

  // Identity: another worker's id without its session, or with none.
  v1::HeartbeatResponse beat;
  EXPECT_STATUS(heartbeat({honest.id, rogue.session}, {theirs.lease_id()}, &beat), PERMISSION_DENIED, "session");
  EXPECT_STATUS(heartbeat({honest.id, ""}, {theirs.lease_id()}, &beat), UNAUTHENTICATED, "no session");
  EXPECT_STATUS(upload({honest.id, rogue.session}, theirs, size, 5.0), PERMISSION_DENIED, "session");
  // Its own identity, another's lease: refused, and the lease stays the honest worker's.
  EXPECT_STATUS(upload(rogue, theirs, size, 5.0), FAILED_PRECONDITION, "is not held by " + rogue.id);
  EXPECT_STATUS(reportFailure(rogue, theirs.lease_id(), job), FAILED_PRECONDITION, "is not held by " + rogue.id);
  ASSERT_TRUE(heartbeat(rogue, {theirs.lease_id()}, &beat).ok());
  ASSERT_EQ(beat.revoked_lease_ids_size(), 1) << "a lease it does not hold is one to drop, not to extend";
  // Its own lease named for another job (a queued one): refused, that job untouched.
  const std::string queued = submit(address, scene);
  EXPECT_STATUS(reportFailure(rogue, mine.lease_id(), queued), FAILED_PRECONDITION, "is for " + job);
  // The spec and assets of a job it holds no lease of.
  EXPECT_STATUS(jobSpec(rogue, queued), FAILED_PRECONDITION, "holds no lease of " + queued);
  EXPECT_STATUS(jobSpec({rogue.id, ""}, job), UNAUTHENTICATED, "no session");
  const std::string objSha = sha256Hex(test::readFile(scene.parent_path() / "meshes/cornell-box.obj"));
  EXPECT_TRUE(fetchAsset(rogue, objSha).ok()) << "an asset of the job it holds a lease of";
  EXPECT_STATUS(fetchAsset(rogue, std::string(64, 'a')), FAILED_PRECONDITION, "belongs to no job");
  // Sums the unit cannot produce, under its own lease: negative, beyond float, wrong counters.
  EXPECT_STATUS(upload(rogue, mine, size, -1.0), INVALID_ARGUMENT, "holds -1");
  EXPECT_STATUS(upload(rogue, mine, size, 1e300), INVALID_ARGUMENT, "at cell 0");
  EXPECT_STATUS(upload(rogue, mine, size, 1.0, std::numeric_limits<uint64_t>::max()), INVALID_ARGUMENT, "paths");
  const auto status = cli({"status", job, "--coordinator", address});
  EXPECT_NE(status.out.find("running"), std::string::npos) << status.out;
  EXPECT_NE(cli({"status", queued, "--coordinator", address}).out.find("queued"), std::string::npos);

  // The rogue leaves; an honest worker process renders the rest (the two raw leases lapse or
  // are revoked and go back to the queue): the image is the in-process render's, bit for bit.
  ASSERT_EQ(cli({"cancel", queued, "--coordinator", address}).exitCode, 0);
  stub_.reset();
  startWorker(address, "w1");
  const auto watched = cli({"watch", job, "--coordinator", address});
  ASSERT_EQ(watched.exitCode, 0) << watched.err;
  expectFarmImageIsTheLocalRender(address, job, scene, "a rogue worker must not change a single bit");
}

}  // namespace
}  // namespace lensfarm
