#pragma once
// The HTTP/JSON API (docs/api.md): every ClientService call over HTTP, for pipelines and tools
// that do not speak gRPC. It is a transcoding, in the manner of google.api.http and grpc-gateway:
// each route (RestOperation) names one RPC, its path and query parameters set fields of the RPC's
// request by name, a JSON body is the request in the protobuf JSON mapping (field names as in the
// proto; 64-bit integers as strings; enums by name), and the answer is the response message in
// the same mapping. The call goes to the coordinator's own gRPC server through an in-process
// channel with the request's Authorization header, so tokens, users, roles and every check are
// exactly the gRPC service's. A gRPC status becomes the HTTP status of Google's mapping
// (httpStatusOf) with a body {"error": {"code", "status", "message"}}.
//
// Beyond the unary calls: GET .../image streams Download's chunks as the body (the EXR or PNG),
// PUT /api/v1/assets/{sha256} uploads the body as one asset (UploadAsset), and
// GET /api/v1/events/stream is ListEvents as Server-Sent Events. The OpenAPI 3.0 document of it
// all (openApiDocument) is generated from the same table and the proto's descriptors, served at
// GET /api/v1/openapi.json and kept in docs/api/openapi.json (a test checks they are the same).
#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "coordinator/rpc/auth.h"
#include "coordinator/web/http_server.h"

namespace lensfarm {

struct RestOperation {
  enum class Body { kNone, kJson, kBytes };
  enum class Reply { kJson, kFile, kEventStream };
  std::string method;  // HTTP
  std::string path;    // with {field} parameters, e.g. /api/v1/jobs/{job_id}
  std::string rpc;     // the lensfarm.v1.ClientService method
  Body body = Body::kNone;
  Reply reply = Reply::kJson;
  std::string summary;
  std::vector<std::string> queryFields;  // the request fields the query may set
};

// The routes, in the order they are matched.
const std::vector<RestOperation>& restOperations();

// A message in the API's JSON: the protobuf JSON mapping with the proto's field names, every
// field printed (zeros too).
std::string protoJson(const google::protobuf::Message& message);

// The HTTP status of a gRPC status code (Google's mapping: google/rpc/code.proto).
int httpStatusOf(grpc::StatusCode code);

class RestApi {
 public:
  // The most Server-Sent Events streams open at once (each polls the feed; more: 429).
  static constexpr int kMaxEventStreams = 64;
  // The largest asset one PUT uploads (larger ones go through gRPC's UploadAsset, which streams).
  static constexpr size_t kMaxAssetBodyBytes = size_t(256) << 20;

  // `channel`: the coordinator's gRPC server in process (grpc::Server::InProcessChannel).
  // `gate`: the client service's, to refuse an upload before its body is read. `tokenRequired`:
  // false for an open (loopback-only) coordinator, which then answers only loopback Host names.
  RestApi(std::shared_ptr<grpc::Channel> channel, TokenGate gate, bool tokenRequired);

  // Adds the /api/v1 routes (and GET /api/v1/openapi.json, public) to `routes`.
  void addRoutes(HttpRoutes& routes);

 private:
  void unary(const RestOperation& op, const HttpRequest& request, HttpResponse& response) const;
  void download(const HttpRequest& request, HttpResponse& response) const;
  void upload(const HttpRequest& request, HttpResponse& response) const;
  void eventStream(const HttpRequest& request, HttpResponse& response);
  HttpGuard guard(const RestOperation& op) const;

  std::shared_ptr<grpc::Channel> channel_;
  TokenGate gate_;
  bool tokenRequired_;
  std::shared_ptr<std::atomic<int>> openStreams_ = std::make_shared<std::atomic<int>>(0);
};

}  // namespace lensfarm
