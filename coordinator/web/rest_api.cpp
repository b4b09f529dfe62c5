#include "coordinator/web/rest_api.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/generic/generic_stub.h>

#include <nlohmann/json.hpp>

#include <charconv>
#include <chrono>
#include <cmath>
#include <future>
#include <regex>

#include "common/util/error.h"
#include "coordinator/web/dashboard_server.h"
#include "coordinator/web/openapi.h"
#include "lensfarm/v1/client_service.grpc.pb.h"

namespace lensfarm {

namespace {

namespace pb = google::protobuf;
using B = RestOperation::Body;
using R = RestOperation::Reply;

constexpr const char* kService = "lensfarm.v1.ClientService";
constexpr const char* kJson = "application/json";

}  // namespace

const std::vector<RestOperation>& restOperations() {
  // clang-format off: one route a line, as a table
  static const std::vector<RestOperation> operations{
      {"GET",
       "/api/v1/jobs",
       "ListJobs",
       B::kNone,
       R::kJson,
       "List the jobs, in the order they are served",
       {"state_names", "owner", "name_contains", "limit"}},
      {"POST",
       "/api/v1/jobs",
       "SubmitJob",
       B::kJson,
       R::kJson,
       "Submit a job (a SubmitJobRequest; upload its assets first)",
       {}},
      {"GET", "/api/v1/jobs/{job_id}", "GetJob", B::kNone, R::kJson, "A job's status", {}},
      {"PATCH",
       "/api/v1/jobs/{job_id}",
       "UpdateJob",
       B::kJson,
       R::kJson,
       "Change a job's priority, worker cap or share weight",
       {}},
      {"DELETE",
       "/api/v1/jobs/{job_id}",
       "DeleteJob",
       B::kNone,
       R::kJson,
       "Delete a job for good (force: cancel a running one first)",
       {"force"}},
      {"POST", "/api/v1/jobs/{job_id}/cancel", "CancelJob", B::kJson, R::kJson, "Cancel a job", {}},
      {"POST",
       "/api/v1/jobs/{job_id}/pause",
       "PauseJob",
       B::kJson,
       R::kJson,
       "Pause a job (units in flight finish and count)",
       {}},
      {"POST", "/api/v1/jobs/{job_id}/resume", "ResumeJob", B::kJson, R::kJson, "Resume a paused job", {}},
      {"POST",
       "/api/v1/jobs/{job_id}/approve",
       "ApproveJob",
       B::kJson,
       R::kJson,
       "Approve a job (jobs waiting for JOB:approved start)",
       {}},
      {"POST",
       "/api/v1/jobs/{job_id}/prefetch",
       "PrefetchJob",
       B::kJson,
       R::kJson,
       "Have the workers that may render the job fetch its assets now",
       {}},
      {"POST",
       "/api/v1/jobs/{job_id}/archive",
       "ArchiveJob",
       B::kJson,
       R::kJson,
       "Keep an ended job's final image and free the rest",
       {}},
      {"GET",
       "/api/v1/jobs/{job_id}/image",
       "Download",
       B::kNone,
       R::kFile,
       "The image as it is now: EXR (linear) or PNG (exposed)",
       {"format", "ev", "frame"}},
      {"GET",
       "/api/v1/jobs/{job_id}/snapshot",
       "GetSnapshot",
       B::kNone,
       R::kJson,
       "A small exposed preview (PNG, base64) with the job's status",
       {"max_size", "ev", "frame"}},
      {"GET", "/api/v1/workers", "ListWorkers", B::kNone, R::kJson, "The workers the coordinator knows", {}},
      {"GET",
       "/api/v1/info",
       "GetServerInfo",
       B::kNone,
       R::kJson,
       "The coordinator's version and API, and who the caller is to it",
       {}},
      {"GET",
       "/api/v1/events",
       "ListEvents",
       B::kNone,
       R::kJson,
       "The farm's events after a sequence number",
       {"after", "limit", "job_id"}},
      {"GET",
       "/api/v1/events/stream",
       "ListEvents",
       B::kNone,
       R::kEventStream,
       "The farm's events as Server-Sent Events, as they happen",
       {"after", "job_id"}},
      {"POST",
       "/api/v1/assets/missing",
       "FindMissingAssets",
       B::kJson,
       R::kJson,
       "Which of the listed assets (by SHA-256) the coordinator lacks",
       {}},
      {"PUT",
       "/api/v1/assets/{sha256}",
       "UploadAsset",
       B::kBytes,
       R::kJson,
       "Upload one asset: the body is its bytes, checked against the SHA-256",
       {}},
  };
  // clang-format on
  return operations;
}

std::string protoJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string out;
  const auto printed = google::protobuf::util::MessageToJsonString(message, &out, options);
  if (!printed.ok()) throw std::runtime_error("cannot print " + message.GetTypeName() + " as JSON");
  return out;
}

int httpStatusOf(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return 200;
    case grpc::StatusCode::CANCELLED: return 499;
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE: return 400;
    case grpc::StatusCode::DEADLINE_EXCEEDED: return 504;
    case grpc::StatusCode::NOT_FOUND: return 404;
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::ABORTED: return 409;
    case grpc::StatusCode::PERMISSION_DENIED: return 403;
    case grpc::StatusCode::UNAUTHENTICATED: return 401;
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return 429;
    case grpc::StatusCode::UNIMPLEMENTED: return 501;
    case grpc::StatusCode::UNAVAILABLE: return 503;
    default: return 500;  // UNKNOWN, INTERNAL, DATA_LOSS
  }
}

namespace {

const char* statusName(grpc::StatusCode code) {
  static constexpr const char* kNames[] = {
      "OK",        "CANCELLED",      "UNKNOWN",           "INVALID_ARGUMENT",   "DEADLINE_EXCEEDED",
      "NOT_FOUND", "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
      "ABORTED",   "OUT_OF_RANGE",   "UNIMPLEMENTED",     "INTERNAL",           "UNAVAILABLE",
      "DATA_LOSS", "UNAUTHENTICATED"};
  const auto i = size_t(code);
  return i < std::size(kNames) ? kNames[i] : "UNKNOWN";
}

void fail(HttpResponse& response, const grpc::Status& status) {
  const int http = httpStatusOf(status.error_code());
  response.status = http;
  if (http == 401) response.setHeader("WWW-Authenticate", "Bearer");
  response.setContent(
      nlohmann::json{
          {"error", {{"code", http}, {"status", statusName(status.error_code())}, {"message", status.error_message()}}}}
          .dump(),
      kJson);
}

grpc::Status invalid(const std::string& message) { return {grpc::StatusCode::INVALID_ARGUMENT, message}; }

// A call's context: the request's Authorization as the call's, and a deadline.
std::unique_ptr<grpc::ClientContext> callContext(const HttpRequest& request, std::optional<double> seconds) {
  auto context = std::make_unique<grpc::ClientContext>();
  if (const std::string authorization = request.header("Authorization"); !authorization.empty())
    context->AddMetadata("authorization", authorization);
  if (seconds)
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(int64_t(*seconds * 1000)));
  return context;
}

// An Authorization value gRPC metadata can carry (printable ASCII), or a status refusing it.
grpc::Status checkAuthorizationText(const HttpRequest& request) {
  for (const char c : request.header("Authorization"))
    if (c < 0x20 || c > 0x7e) return {grpc::StatusCode::UNAUTHENTICATED, "Authorization: not printable ASCII"};
  return grpc::Status::OK;
}

std::unique_ptr<pb::Message> newMessage(const pb::Descriptor* type) {
  return std::unique_ptr<pb::Message>(pb::MessageFactory::generated_factory()->GetPrototype(type)->New());
}

const pb::MethodDescriptor& methodOf(const std::string& rpc) {
  const pb::ServiceDescriptor* service = pb::DescriptorPool::generated_pool()->FindServiceByName(kService);
  const pb::MethodDescriptor* method = service ? service->FindMethodByName(rpc) : nullptr;
  if (!method) throw std::logic_error("no RPC " + rpc);
  return *method;
}

template <class Int>
bool parseInteger(const std::string& text, Int& value) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size() && !text.empty();
}

// Sets field `name` of `message` from a path or query parameter's text, by the field's type;
// a status naming the parameter if it is not one of the request's or its value does not parse.
grpc::Status setField(pb::Message& message, const std::string& name, const std::string& value) {
  const pb::FieldDescriptor* field = message.GetDescriptor()->FindFieldByName(name);
  if (!field || field->cpp_type() == pb::FieldDescriptor::CPPTYPE_MESSAGE)
    return invalid("parameter " + name + ": not a parameter of this operation");
  const pb::Reflection& r = *message.GetReflection();
  const bool repeated = field->is_repeated();
  const auto bad = [&](const char* expected) {
    return invalid("parameter " + name + ": expected " + expected + ", got \"" + value + "\"");
  };
  switch (field->cpp_type()) {
    case pb::FieldDescriptor::CPPTYPE_INT32: {
      int32_t v = 0;
      if (!parseInteger(value, v)) return bad("a 32-bit integer");
      repeated ? r.AddInt32(&message, field, v) : r.SetInt32(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_INT64: {
      int64_t v = 0;
      if (!parseInteger(value, v)) return bad("a 64-bit integer");
      repeated ? r.AddInt64(&message, field, v) : r.SetInt64(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_UINT32: {
      uint32_t v = 0;
      if (!parseInteger(value, v)) return bad("an unsigned 32-bit integer");
      repeated ? r.AddUInt32(&message, field, v) : r.SetUInt32(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_UINT64: {
      uint64_t v = 0;
      if (!parseInteger(value, v)) return bad("an unsigned 64-bit integer");
      repeated ? r.AddUInt64(&message, field, v) : r.SetUInt64(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_DOUBLE:
    case pb::FieldDescriptor::CPPTYPE_FLOAT: {
      char* end = nullptr;
      const double v = value.empty() ? NAN : std::strtod(value.c_str(), &end);
      if (!std::isfinite(v) || end != value.c_str() + value.size()) return bad("a finite number");
      if (field->cpp_type() == pb::FieldDescriptor::CPPTYPE_FLOAT)
        repeated ? r.AddFloat(&message, field, float(v)) : r.SetFloat(&message, field, float(v));
      else
        repeated ? r.AddDouble(&message, field, v) : r.SetDouble(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_BOOL: {
      if (value != "true" && value != "false" && value != "1" && value != "0") return bad("true or false");
      const bool v = value == "true" || value == "1";
      repeated ? r.AddBool(&message, field, v) : r.SetBool(&message, field, v);
      break;
    }
    case pb::FieldDescriptor::CPPTYPE_STRING:
      repeated ? r.AddString(&message, field, value) : r.SetString(&message, field, value);
      break;
    case pb::FieldDescriptor::CPPTYPE_ENUM: {
      // By its full name (IMAGE_FORMAT_EXR) or, case-insensitively, without the enum's prefix (exr).
      const pb::EnumDescriptor* type = field->enum_type();
      const pb::EnumValueDescriptor* v = type->FindValueByName(value);
      std::string names;
      for (int i = 0; !v && i < type->value_count(); ++i) {
        const std::string& full = type->value(i)->name();
        const size_t underscore = full.size() > value.size() ? full.size() - value.size() - 1 : std::string::npos;
        if (underscore != std::string::npos && full[underscore] == '_' &&
            std::equal(value.begin(), value.end(), full.begin() + long(underscore) + 1,
                       [](char a, char b) { return std::toupper((unsigned char)a) == b; }))
          v = type->value(i);
      }
      if (!v) {
        for (int i = 0; i < type->value_count(); ++i) names += (names.empty() ? "" : ", ") + type->value(i)->name();
        return bad(("one of " + names).c_str());
      }
      repeated ? r.AddEnumValue(&message, field, v->number()) : r.SetEnumValue(&message, field, v->number());
      break;
    }
    default: return invalid("parameter " + name + ": not settable");
  }
  return grpc::Status::OK;
}

// The operation's path as a regex (each {field} one segment) and its parameters' names.
std::pair<std::string, std::vector<std::string>> pathPattern(const std::string& path) {
  std::string pattern;
  std::vector<std::string> names;
  for (size_t i = 0; i < path.size();) {
    if (path[i] == '{') {
      const size_t close = path.find('}', i);
      names.push_back(path.substr(i + 1, close - i - 1));
      pattern += "([A-Za-z0-9._~-]+)";
      i = close + 1;
    } else {
      if (std::string_view(".+*?()[]{}|^$\\").find(path[i]) != std::string_view::npos) pattern += '\\';
      pattern += path[i++];
    }
  }
  return {pattern, names};
}

// The RPC's request from the HTTP request: the JSON body (the whole message), then the path
// parameters (named by `names`, values in request.matches), then the query.
grpc::Status requestOf(const RestOperation& op, const std::vector<std::string>& names, const HttpRequest& request,
                       pb::Message& message) {
  if (op.body == B::kJson && request.body.find_first_not_of(" \t\r\n") != std::string::npos) {
    pb::util::JsonParseOptions options;
    options.ignore_unknown_fields = false;
    const auto parsed = pb::util::JsonStringToMessage(request.body, &message, options);
    if (!parsed.ok()) return invalid("body: " + std::string(parsed.message()));
  }
  for (size_t i = 0; i < names.size(); ++i)
    if (auto s = setField(message, names[i], request.matches[i + 1]); !s.ok()) return s;
  for (const auto& [key, value] : request.query) {
    if (std::find(op.queryFields.begin(), op.queryFields.end(), key) == op.queryFields.end()) {
      std::string allowed;
      for (const std::string& f : op.queryFields) allowed += (allowed.empty() ? "" : ", ") + f;
      return invalid("parameter " + key +
                     ": not a parameter of this operation (it takes: " + (allowed.empty() ? "none" : allowed) + ")");
    }
    if (auto s = setField(message, key, value); !s.ok()) return s;
  }
  return grpc::Status::OK;
}

// One unary call through the channel, by the RPC's name, with messages of any type.
grpc::Status callUnary(const std::shared_ptr<grpc::Channel>& channel, const std::string& rpc,
                       grpc::ClientContext& context, const pb::Message& request, pb::Message& response) {
  grpc::GenericStub stub(channel);
  std::string bytes;
  request.SerializeToString(&bytes);
  grpc::Slice slice(bytes);
  grpc::ByteBuffer in(&slice, 1), out;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, std::string("/") + kService + "/" + rpc, grpc::StubOptions(), &in, &out,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  grpc::Status status = done.get_future().get();
  if (!status.ok()) return status;
  std::vector<grpc::Slice> slices;
  out.Dump(&slices);
  std::string answer;
  for (const grpc::Slice& s : slices) answer.append(reinterpret_cast<const char*>(s.begin()), s.size());
  if (!response.ParseFromString(answer)) return {grpc::StatusCode::INTERNAL, "unreadable answer of " + rpc};
  return status;
}

std::optional<double> deadlineOf(const std::string& rpc) {
  if (rpc == "ArchiveJob" || rpc == "DeleteJob") return std::nullopt;  // writes or waits for a whole image
  return 60.0;
}

}  // namespace

RestApi::RestApi(std::shared_ptr<grpc::Channel> channel, TokenGate gate, bool tokenRequired)
    : channel_(std::move(channel)), gate_(std::move(gate)), tokenRequired_(tokenRequired) {}

HttpGuard RestApi::guard(const RestOperation& op) const {
  return [this, op](const HttpRequest& request, HttpResponse& response) {
    // Without a token, only requests addressed to this machine by a loopback name (no DNS
    // rebinding); a JSON body or an action needs a JSON content type (a form on another site
    // cannot send one without a CORS preflight, which this server never grants).
    if (!tokenRequired_ && !loopbackHost(request.header("Host"))) {
      fail(response,
           {grpc::StatusCode::PERMISSION_DENIED, "without a client token the API answers only requests to localhost"});
      return true;
    }
    if (op.body == B::kJson && request.header("Content-Type").rfind(kJson, 0) != 0) {
      fail(response, invalid(op.method + " " + request.path + ": send a JSON body (Content-Type: application/json)"));
      response.status = 415;
      return true;
    }
    if (const grpc::Status text = checkAuthorizationText(request); !text.ok()) {
      fail(response, text);
      return true;
    }
    if (op.body == B::kBytes) {  // refused before its body is read
      const grpc::Status allowed =
          gate_.checkAuthorization(request.header("Authorization"), op.rpc.c_str(), request.remoteAddress);
      if (!allowed.ok()) {
        fail(response, allowed);
        return true;
      }
    }
    return false;
  };
}

void RestApi::addRoutes(HttpRoutes& routes) {
  routes.get("/api/v1/openapi\\.json", [](const HttpRequest&, HttpResponse& response) {
    static const std::string document = openApiDocument("1");
    response.setContent(document, kJson);
    response.setHeader("Cache-Control", "no-cache");
  });
  for (const RestOperation& op : restOperations()) {
    auto [pattern, names] = pathPattern(op.path);
    HttpHandler handler;
    if (op.reply == R::kFile) {
      handler = [this](const HttpRequest& request, HttpResponse& response) { download(request, response); };
    } else if (op.reply == R::kEventStream) {
      handler = [this](const HttpRequest& request, HttpResponse& response) { eventStream(request, response); };
    } else if (op.body == B::kBytes) {
      handler = [this](const HttpRequest& request, HttpResponse& response) { upload(request, response); };
    } else {
      handler = [this, &op](const HttpRequest& request, HttpResponse& response) { unary(op, request, response); };
    }
    routes.add(
        op.method, pattern,
        [handler, &op](const HttpRequest& request, HttpResponse& response) {
          response.setHeader("Cache-Control", "no-store");
          handler(request, response);
        },
        guard(op), op.body == B::kBytes ? kMaxAssetBodyBytes : (op.body == B::kJson ? size_t(8) << 20 : 0));
  }
}

void RestApi::unary(const RestOperation& op, const HttpRequest& request, HttpResponse& response) const {
  const pb::MethodDescriptor& method = methodOf(op.rpc);
  const auto message = newMessage(method.input_type());
  const auto answer = newMessage(method.output_type());
  if (grpc::Status s = requestOf(op, pathPattern(op.path).second, request, *message); !s.ok()) return fail(response, s);
  const auto context = callContext(request, deadlineOf(op.rpc));
  if (grpc::Status s = callUnary(channel_, op.rpc, *context, *message, *answer); !s.ok()) return fail(response, s);
  response.setContent(protoJson(*answer), kJson);
}

namespace {

// A Download call in progress: closed (cancelled if unfinished) when the HTTP response ends.
struct DownloadCall {
  std::unique_ptr<grpc::ClientContext> context;
  std::unique_ptr<v1::ClientService::Stub> stub;
  std::unique_ptr<grpc::ClientReader<v1::FileChunk>> reader;
  std::string first;  // the first chunk, read before the response's status was chosen
  bool finished = false;
  ~DownloadCall() {
    if (reader && !finished) {
      context->TryCancel();
      reader->Finish();
    }
  }
};

}  // namespace

void RestApi::download(const HttpRequest& request, HttpResponse& response) const {
  static const RestOperation& op = *std::find_if(restOperations().begin(), restOperations().end(),
                                                 [](const RestOperation& o) { return o.rpc == "Download"; });
  v1::DownloadRequest message;
  if (grpc::Status s = requestOf(op, pathPattern(op.path).second, request, message); !s.ok()) return fail(response, s);
  if (message.format() == v1::IMAGE_FORMAT_UNSPECIFIED) message.set_format(v1::IMAGE_FORMAT_EXR);
  auto call = std::make_shared<DownloadCall>();
  call->context = callContext(request, std::nullopt);
  call->stub = v1::ClientService::NewStub(channel_);
  call->reader = call->stub->Download(call->context.get(), message);
  v1::FileChunk chunk;
  if (!call->reader->Read(&chunk)) {
    call->finished = true;
    grpc::Status status = call->reader->Finish();
    if (status.ok()) status = {grpc::StatusCode::INTERNAL, "the image was empty"};
    return fail(response, status);
  }
  call->first = std::move(*chunk.mutable_data());
  const bool exr = message.format() == v1::IMAGE_FORMAT_EXR;
  response.setHeader("Content-Type", exr ? "image/x-exr" : "image/png");
  response.setHeader("Content-Disposition",
                     "attachment; filename=\"" + message.job_id() + (exr ? ".exr" : ".png") + "\"");
  if (chunk.total_size()) response.setHeader("X-Total-Size", std::to_string(chunk.total_size()));
  response.stream = std::make_shared<HttpStream>();
  response.stream->next = [call]() -> std::optional<std::string> {
    if (!call->first.empty()) return std::exchange(call->first, std::string());
    v1::FileChunk next;
    while (call->reader->Read(&next))
      if (!next.data().empty()) return std::move(*next.mutable_data());
    call->finished = true;
    const grpc::Status status = call->reader->Finish();
    if (!status.ok()) throw std::runtime_error("download ended: " + status.error_message());  // (cut short)
    return std::nullopt;
  };
}

void RestApi::upload(const HttpRequest& request, HttpResponse& response) const {
  const std::string& sha256 = request.matches[1];
  const auto context = callContext(request, 600.0);
  const auto stub = v1::ClientService::NewStub(channel_);
  v1::UploadAssetResponse answer;
  const auto writer = stub->UploadAsset(context.get(), &answer);
  constexpr size_t kChunk = size_t(1) << 20;
  const std::string& bytes = request.body;
  for (size_t offset = 0; offset == 0 || offset < bytes.size(); offset += kChunk) {
    v1::UploadAssetRequest part;
    if (offset == 0) {
      part.set_sha256(sha256);
      part.mutable_chunk()->set_total_size(bytes.size());
    }
    part.mutable_chunk()->set_data(bytes.substr(offset, kChunk));
    if (!writer->Write(part)) break;  // (the coordinator answered early: it had the asset)
  }
  writer->WritesDone();
  if (grpc::Status s = writer->Finish(); !s.ok()) return fail(response, s);
  response.setContent(protoJson(answer), kJson);
}

namespace {

// A Server-Sent Events stream of ListEvents: each event as "id", "event" (its type) and "data"
// (the FarmEvent in JSON); a comment every 15 s of quiet, so a reader gone is noticed.
struct EventStream {
  std::shared_ptr<grpc::Channel> channel;
  std::string authorization;
  v1::ListEventsRequest request;
  std::string pending;
  std::chrono::steady_clock::time_point lastWrite = std::chrono::steady_clock::now();
  std::shared_ptr<std::atomic<int>> open;
  ~EventStream() { --*open; }

  // The next call's events as SSE text, or a status.
  grpc::Status poll(std::string& text) {
    grpc::ClientContext context;
    if (!authorization.empty()) context.AddMetadata("authorization", authorization);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::ListEventsResponse response;
    const grpc::Status status = callUnary(channel, "ListEvents", context, request, response);
    if (!status.ok()) return status;
    if (request.after() + 1 < response.oldest() && request.after() < response.latest())
      text += "event: missed\ndata: {\"after\":\"" + std::to_string(request.after()) + "\",\"oldest\":\"" +
              std::to_string(response.oldest()) + "\"}\n\n";
    for (const v1::FarmEvent& e : response.events())
      text += "id: " + std::to_string(e.sequence()) + "\nevent: " + e.type() + "\ndata: " + protoJson(e) + "\n\n";
    request.set_after(std::max(request.after(), response.events().empty()
                                                    ? (request.job_id().empty() ? request.after() : response.latest())
                                                    : response.events().rbegin()->sequence()));
    return status;
  }
};

}  // namespace

void RestApi::eventStream(const HttpRequest& request, HttpResponse& response) {
  static const RestOperation& op = *std::find_if(restOperations().begin(), restOperations().end(),
                                                 [](const RestOperation& o) { return o.reply == R::kEventStream; });
  if (++*openStreams_ > kMaxEventStreams) {
    --*openStreams_;
    return fail(response, {grpc::StatusCode::RESOURCE_EXHAUSTED,
                           "at most " + std::to_string(kMaxEventStreams) + " event streams at once"});
  }
  auto stream = std::make_shared<EventStream>();
  stream->open = openStreams_;
  stream->channel = channel_;
  stream->authorization = request.header("Authorization");
  if (grpc::Status s = requestOf(op, {}, request, stream->request); !s.ok()) return fail(response, s);
  // A reconnecting reader's Last-Event-ID resumes after the last event it had.
  if (const std::string last = request.header("Last-Event-ID"); !last.empty()) {
    uint64_t after = 0;
    if (!parseInteger(last, after)) return fail(response, invalid("Last-Event-ID: expected an event's sequence"));
    stream->request.set_after(std::max<uint64_t>(after, stream->request.after()));
  }
  stream->pending = "retry: 2000\n\n";
  if (grpc::Status s = stream->poll(stream->pending); !s.ok()) return fail(response, s);
  response.setHeader("Content-Type", "text/event-stream");
  response.setHeader("X-Accel-Buffering", "no");  // (no buffering in a proxy in front)
  response.stream = std::make_shared<HttpStream>();
  response.stream->next = [stream]() -> std::optional<std::string> {
    std::string text = std::exchange(stream->pending, std::string());
    if (text.empty() && !stream->poll(text).ok()) return std::nullopt;  // (a token revoked: the stream ends)
    const auto now = std::chrono::steady_clock::now();
    if (text.empty() && now - stream->lastWrite > std::chrono::seconds(15)) text = ": keep-alive\n\n";
    if (!text.empty()) stream->lastWrite = now;
    return text;
  };
}

}  // namespace lensfarm
