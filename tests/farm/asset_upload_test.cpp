// ClientService's asset calls over real gRPC on loopback, served in this process by the
// coordinator's own handlers (service.h) so the test sees the Coordinator behind them:
// FindMissingAssets behind the client token and refusing a bad hash by index, UploadAsset
// answering already_present after the first message, and the real `lensfarm submit` against a
// coordinator that predates FindMissingAssets.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <optional>

#include "common/util/hash.h"
#include "coordinator/core/coordinator.h"
#include "coordinator/rpc/service.h"
#include "lensfarm/v1/client_service.grpc.pb.h"
#include "tests/deploy_support.h"
#include "tests/test_support.h"

namespace lensfarm {
namespace {

namespace fs = std::filesystem;

constexpr size_t kMiB = size_t(1) << 20;
const std::string kHello = "5891b5b522d5df086d0ff0b110fbd9d21bb4fc7163af34d08286a2e846f6be03";  // sha256 of "hello\n"

// A coordinator older than FindMissingAssets: the generated base class answers it UNIMPLEMENTED;
// the calls `lensfarm submit` makes besides go to today's handlers.
class OlderClientService final : public v1::ClientService::Service {
 public:
  explicit OlderClientService(ClientServiceImpl& today) : today_(today) {}
  grpc::Status UploadAsset(grpc::ServerContext* context, grpc::ServerReader<v1::UploadAssetRequest>* reader,
                           v1::UploadAssetResponse* response) override {
    return today_.UploadAsset(context, reader, response);
  }
  grpc::Status SubmitJob(grpc::ServerContext* context, const v1::SubmitJobRequest* request,
                         v1::SubmitJobResponse* response) override {
    return today_.SubmitJob(context, request, response);
  }

 private:
  ClientServiceImpl& today_;
};

// A gRPC server on a free loopback port serving `service` until destroyed.
class LoopbackServer {
 public:
  explicit LoopbackServer(grpc::Service& service) {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service);
    server_ = builder.BuildAndStart();
    if (!server_ || port == 0) throw std::runtime_error("cannot serve on loopback");
    address_ = "127.0.0.1:" + std::to_string(port);
  }
  ~LoopbackServer() { server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2)); }
  const std::string& address() const { return address_; }
  std::unique_ptr<v1::ClientService::Stub> stub() const {
    return v1::ClientService::NewStub(grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
  }

 private:
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

// What an UploadAsset call did: its status and answer, and how many messages the client wrote
// before a write failed (the coordinator had ended the call).
struct Upload {
  grpc::Status status;
  v1::UploadAssetResponse response;
  size_t written = 0;
};

// Uploads `bytes` under `sha` in messages of `chunk` bytes, the first declaring `declared` bytes
// in all (the size of `bytes` unless given): with the defaults, the way `lensfarm submit` does.
Upload upload(v1::ClientService::Stub& stub, const std::string& sha, const std::string& bytes, size_t chunk = kMiB,
              std::optional<uint64_t> declared = std::nullopt) {
  grpc::ClientContext context;
  Upload u;
  auto writer = stub.UploadAsset(&context, &u.response);
  for (size_t offset = 0; offset < bytes.size(); offset += chunk) {
    v1::UploadAssetRequest message;
    if (offset == 0) {
      message.set_sha256(sha);
      message.mutable_chunk()->set_total_size(declared.value_or(bytes.size()));
    }
    message.mutable_chunk()->set_data(bytes.substr(offset, chunk));
    if (!writer->Write(message)) break;
    ++u.written;
  }
  writer->WritesDone();
  u.status = writer->Finish();
  return u;
}

v1::FindMissingAssetsRequest query(const std::vector<std::string>& hashes) {
  v1::FindMissingAssetsRequest request;
  for (const auto& h : hashes) request.add_sha256(h);
  return request;
}

TEST(AssetUpload, FindMissingAssetsTakesTheClientTokenAndNamesABadHashByIndex) {
  Coordinator coordinator;
  ASSERT_TRUE(coordinator.putAsset(kHello, "hello\n"));
  ClientServiceImpl service(coordinator, TokenGate(std::string("client-secret"), "client"));
  LoopbackServer server(service);
  auto stub = server.stub();
  const std::string absent(64, 'a');

  const auto call = [&](const v1::FindMissingAssetsRequest& request, const std::string& token,
                        v1::FindMissingAssetsResponse* response) {
    grpc::ClientContext context;
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    return stub->FindMissingAssets(&context, request, response);
  };
  v1::FindMissingAssetsResponse response;
  grpc::Status s = call(query({absent, kHello}), "", &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(s.error_message(), "FindMissingAssets: missing client token");
  s = call(query({absent, kHello}), "worker-secret", &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(s.error_message(), "FindMissingAssets: wrong client token");

  ASSERT_TRUE(call(query({absent, kHello, absent}), "client-secret", &response).ok());
  EXPECT_EQ(std::vector<std::string>(response.missing_sha256().begin(), response.missing_sha256().end()),
            std::vector<std::string>{absent});

  response.Clear();
  s = call(query({kHello, absent, "5891B5B522D5DF086D0FF0B110FBD9D21BB4FC7163AF34D08286A2E846F6BE03"}), "client-secret",
           &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(s.error_message().find("sha256[2]"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find("64 lowercase hex digits"), std::string::npos) << s.error_message();
  EXPECT_EQ(response.missing_sha256_size(), 0);
}

TEST(AssetUpload, AnAssetAlreadyStoredIsAnsweredAfterItsFirstMessage) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  LoopbackServer server(service);
  auto stub = server.stub();

  // 64 MiB the coordinator holds already: the upload ends after the first message.
  std::string big(64 * kMiB, '\0');
  for (size_t i = 0; i < big.size(); ++i) big[i] = char((i * 2654435761u) >> 13);
  const std::string sha = sha256Hex(big);
  ASSERT_TRUE(coordinator.putAsset(sha, big));
  const uint64_t received = coordinator.metricsSnapshot().assetBytesReceived;
  const Upload again = upload(*stub, sha, big);
  ASSERT_TRUE(again.status.ok()) << again.status.error_message();
  EXPECT_TRUE(again.response.already_present());
  EXPECT_EQ(again.response.sha256(), sha);
  EXPECT_EQ(coordinator.metricsSnapshot().assetBytesReceived, received) << "the coordinator read no more of it";
  EXPECT_EQ(coordinator.metricsSnapshot().assetUploadsPresent, 1u);
  EXPECT_LT(again.written, 64u) << "the client's writes failed once the coordinator had answered";

  // A new asset is still read to its end and checked.
  const std::string fresh = big.substr(0, 3 * kMiB + 5);
  const Upload first = upload(*stub, sha256Hex(fresh), fresh);
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  EXPECT_FALSE(first.response.already_present());
  EXPECT_EQ(first.written, 4u);
  EXPECT_EQ(coordinator.metricsSnapshot().assetBytesReceived, received + fresh.size());
  EXPECT_EQ(*coordinator.asset(sha256Hex(fresh)), fresh);
  const Upload corrupt = upload(*stub, std::string(64, 'b'), fresh);
  EXPECT_EQ(corrupt.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

// Each malformed upload is refused with INVALID_ARGUMENT naming what is wrong, and leaves nothing
// stored: the asset is still missing, no upload is counted as stored, a job naming it is refused.
TEST(AssetUpload, AMalformedUploadIsInvalidArgumentNamingTheFaultAndStoresNothing) {
  Coordinator coordinator;
  ClientServiceImpl service(coordinator);
  LoopbackServer server(service);
  auto stub = server.stub();
  std::string bytes(3 * kMiB + 5, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = char((i * 40503u) >> 7);
  const std::string sha = sha256Hex(bytes);
  std::string upper = sha;
  for (char& c : upper) c = char(std::toupper(static_cast<unsigned char>(c)));

  struct Case {
    const char* what;
    std::string sha;
    size_t chunk;
    std::optional<uint64_t> declared;
    std::string message;
  };
  for (const Case& c : std::vector<Case>{
           {"2 MiB chunks", sha, 2 * kMiB, std::nullopt,
            "UploadAsset: chunk[0] is 2097152 bytes; a chunk is at most 1 MiB (1048576 bytes)"},
           {"declared short", sha, kMiB, bytes.size() - 1,
            "UploadAsset: chunk[3] goes past the declared total_size: 3145733 bytes of 3145732"},
           {"declared long", sha, kMiB, bytes.size() + 1,
            "UploadAsset: the stream ended after 3145733 bytes of the declared total_size 3145734"},
           {"nothing declared", sha, kMiB, 0,
            "UploadAsset: chunk[0] goes past the declared total_size: 1048576 bytes of 0"},
           {"uppercase hash", upper, kMiB, std::nullopt,
            "UploadAsset: sha256: \"" + upper + "\" is not a SHA-256 (64 lowercase hex digits)"},
       }) {
    const Upload u = upload(*stub, c.sha, bytes, c.chunk, c.declared);
    EXPECT_EQ(u.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.what << ": " << u.status.error_message();
    EXPECT_EQ(u.status.error_message(), c.message) << c.what;
    EXPECT_EQ(coordinator.missingAssets({sha}), std::vector<std::string>{sha}) << c.what << ": nothing stored";
  }
  EXPECT_EQ(coordinator.metricsSnapshot().assetUploadsStored, 0u);
  EXPECT_EQ(coordinator.metricsSnapshot().assetBytesReceived, 0u) << "no refused upload reached the store";

  // A job naming the asset by an uppercase hash: the same rule, not a missing asset.
  JobSpec spec;
  spec.sceneName = "scene.json";
  spec.sceneJson = test::minimalSceneJson().dump();
  spec.assets["mesh.obj"] = upper;
  try {
    coordinator.submit(spec, 0);
    ADD_FAILURE() << "an uppercase hash must be refused";
  } catch (const FarmError& e) {
    EXPECT_EQ(e.kind(), FarmError::Kind::kInvalidArgument);
    EXPECT_EQ(std::string(e.what()),
              "assets[mesh.obj].sha256: \"" + upper + "\" is not a SHA-256 (64 lowercase hex digits)");
  }

  // The same bytes, well formed: stored.
  const Upload good = upload(*stub, sha, bytes);
  ASSERT_TRUE(good.status.ok()) << good.status.error_message();
  EXPECT_FALSE(good.response.already_present());
  EXPECT_EQ(*coordinator.asset(sha), bytes);
}

TEST(AssetUpload, SubmitUploadsEveryAssetToACoordinatorWithoutFindMissingAssets) {
  Coordinator coordinator;
  ClientServiceImpl today(coordinator);
  OlderClientService older(today);
  LoopbackServer server(older);
  test::TempDir dir;
  const fs::path scene = test::writeSeedScene(dir, 16, 2, 1);
  // A mesh of several chunks: its comments make it 6 MB.
  std::string mesh = test::readFile(dir / "meshes/cornell-box.obj");
  for (int i = 0; mesh.size() < 6 * kMiB; ++i) mesh += "# padding line " + std::to_string(i) + " of a big mesh\n";
  dir.write("meshes/cornell-box.obj", mesh);

  test::FarmProcesses farm(dir);
  const auto first = farm.cli({"submit", scene.string(), "--coordinator", server.address()});
  ASSERT_EQ(first.exitCode, 0) << first.err;
  EXPECT_EQ(first.out, "job-1\n");
  EXPECT_TRUE(test::contains(first.err, "cannot say which assets it holds (no FindMissingAssets): uploading all 1"));
  EXPECT_TRUE(test::contains(first.err, "assets: 1 uploaded (6.29 MB), 0 skipped"));
  EXPECT_EQ(coordinator.metricsSnapshot().assetBytesReceived, mesh.size());

  // Again: the coordinator answers already_present after the first message; submit goes on.
  const auto second = farm.cli({"submit", scene.string(), "--coordinator", server.address()});
  ASSERT_EQ(second.exitCode, 0) << second.err;
  EXPECT_EQ(second.out, "job-2\n");
  EXPECT_TRUE(
      test::contains(second.err, "assets: 0 uploaded (0.00 MB), 1 skipped, already on the coordinator (6.29 MB)"));
  EXPECT_EQ(coordinator.metricsSnapshot().assetBytesReceived, mesh.size());
  EXPECT_EQ(coordinator.metricsSnapshot().assetUploadsStored, 1u);
  EXPECT_EQ(coordinator.metricsSnapshot().assetUploadsPresent, 1u) << "uploaded again, answered early";
  EXPECT_EQ(coordinator.jobs().size(), 2u);
}

}  // namespace
}  // namespace lensfarm
