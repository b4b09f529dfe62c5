#include "coordinator/web/openapi.h"

#include <google/protobuf/descriptor.h>

#include <nlohmann/json.hpp>

#include <set>

#include "coordinator/web/rest_api.h"

namespace lensfarm {

namespace {

namespace pb = google::protobuf;
using nlohmann::json;

std::string refOf(const std::string& name) { return "#/components/schemas/" + name; }

class Schemas {
 public:
  // The schema of one field (its items' for a repeated field wrapped in an array).
  json field(const pb::FieldDescriptor& f) {
    if (f.is_map()) return json{{"type", "object"}, {"additionalProperties", field(*f.message_type()->map_value())}};
    json one;
    switch (f.type()) {
      case pb::FieldDescriptor::TYPE_INT32:
      case pb::FieldDescriptor::TYPE_SINT32:
      case pb::FieldDescriptor::TYPE_SFIXED32: one = {{"type", "integer"}, {"format", "int32"}}; break;
      case pb::FieldDescriptor::TYPE_UINT32:
      case pb::FieldDescriptor::TYPE_FIXED32:
        one = {{"type", "integer"}, {"format", "int64"}, {"minimum", 0}, {"maximum", 4294967295u}};
        break;
      case pb::FieldDescriptor::TYPE_INT64:
      case pb::FieldDescriptor::TYPE_SINT64:
      case pb::FieldDescriptor::TYPE_SFIXED64:
        one = {{"type", "string"}, {"format", "int64"}, {"pattern", "^-?[0-9]+$"}};
        break;
      case pb::FieldDescriptor::TYPE_UINT64:
      case pb::FieldDescriptor::TYPE_FIXED64:
        one = {{"type", "string"}, {"format", "uint64"}, {"pattern", "^[0-9]+$"}};
        break;
      case pb::FieldDescriptor::TYPE_DOUBLE: one = {{"type", "number"}, {"format", "double"}}; break;
      case pb::FieldDescriptor::TYPE_FLOAT: one = {{"type", "number"}, {"format", "float"}}; break;
      case pb::FieldDescriptor::TYPE_BOOL: one = {{"type", "boolean"}}; break;
      case pb::FieldDescriptor::TYPE_STRING: one = {{"type", "string"}}; break;
      case pb::FieldDescriptor::TYPE_BYTES: one = {{"type", "string"}, {"format", "byte"}}; break;
      case pb::FieldDescriptor::TYPE_ENUM: one = {{"$ref", refOf(addEnum(*f.enum_type()))}}; break;
      default: one = {{"$ref", refOf(addMessage(*f.message_type()))}}; break;
    }
    return f.is_repeated() ? json{{"type", "array"}, {"items", one}} : one;
  }

  std::string addMessage(const pb::Descriptor& type) {
    const std::string name = type.name();
    if (!done_.insert(name).second) return name;
    json properties = json::object();
    for (int i = 0; i < type.field_count(); ++i) properties[type.field(i)->name()] = field(*type.field(i));
    schemas_[name] = {{"type", "object"}, {"properties", properties}, {"additionalProperties", false}};
    return name;
  }

  std::string addEnum(const pb::EnumDescriptor& type) {
    const std::string name = type.name();
    if (!done_.insert(name).second) return name;
    json values = json::array();
    for (int i = 0; i < type.value_count(); ++i) values.push_back(type.value(i)->name());
    schemas_[name] = {{"type", "string"}, {"enum", values}};
    return name;
  }

  json take() { return std::move(schemas_); }

 private:
  std::set<std::string> done_;
  json schemas_ = json::object();
};

json jsonContent(const std::string& schemaName) {
  return {{"application/json", {{"schema", {{"$ref", refOf(schemaName)}}}}}};
}

json operationOf(const RestOperation& op, Schemas& schemas) {
  const pb::ServiceDescriptor* service =
      pb::DescriptorPool::generated_pool()->FindServiceByName("lensfarm.v1.ClientService");
  const pb::MethodDescriptor* method = service->FindMethodByName(op.rpc);
  const pb::Descriptor& input = *method->input_type();
  json o{{"operationId", op.reply == RestOperation::Reply::kEventStream ? "StreamEvents" : op.rpc},
         {"summary", op.summary},
         {"x-grpc-method", "lensfarm.v1.ClientService/" + op.rpc}};
  json parameters = json::array();
  for (size_t open = op.path.find('{'); open != std::string::npos; open = op.path.find('{', open + 1)) {
    const std::string name = op.path.substr(open + 1, op.path.find('}', open) - open - 1);
    parameters.push_back(
        {{"name", name}, {"in", "path"}, {"required", true}, {"schema", schemas.field(*input.FindFieldByName(name))}});
  }
  for (const std::string& name : op.queryFields) {
    const pb::FieldDescriptor& f = *input.FindFieldByName(name);
    json p{{"name", name}, {"in", "query"}, {"required", false}, {"schema", schemas.field(f)}};
    if (f.is_repeated()) p["explode"] = true;
    parameters.push_back(p);
  }
  if (op.reply == RestOperation::Reply::kEventStream)
    parameters.push_back({{"name", "Last-Event-ID"},
                          {"in", "header"},
                          {"required", false},
                          {"schema", {{"type", "string"}, {"pattern", "^[0-9]+$"}}}});
  if (!parameters.empty()) o["parameters"] = parameters;
  if (op.body == RestOperation::Body::kJson)
    o["requestBody"] = {{"required", op.rpc == "SubmitJob" || op.rpc == "UpdateJob" || op.rpc == "FindMissingAssets"},
                        {"content", jsonContent(schemas.addMessage(input))}};
  if (op.body == RestOperation::Body::kBytes)
    o["requestBody"] = {
        {"required", true},
        {"content", {{"application/octet-stream", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}};
  json ok;
  switch (op.reply) {
    case RestOperation::Reply::kJson:
      ok = {{"description", "the " + method->output_type()->name() + " message"},
            {"content", jsonContent(schemas.addMessage(*method->output_type()))}};
      break;
    case RestOperation::Reply::kFile:
      ok = {{"description", "the image file (format=exr: OpenEXR, linear; format=png: exposed 8-bit sRGB)"},
            {"content",
             {{"image/x-exr", {{"schema", {{"type", "string"}, {"format", "binary"}}}}},
              {"image/png", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}};
      break;
    case RestOperation::Reply::kEventStream:
      ok = {{"description",
             "Server-Sent Events: each FarmEvent as `id: SEQUENCE`, `event: TYPE` and `data: FarmEvent JSON`; an "
             "`event: missed` when events after `after` are no longer held; a comment every 15 s of quiet"},
            {"content", {{"text/event-stream", {{"schema", {{"type", "string"}}}}}}}};
      schemas.addMessage(*pb::DescriptorPool::generated_pool()->FindMessageTypeByName("lensfarm.v1.FarmEvent"));
      break;
  }
  o["responses"] = {{"200", ok},
                    {"default",
                     {{"description", "an error: the gRPC status as its HTTP status (docs/api.md)"},
                      {"content", jsonContent("Error")}}}};
  return o;
}

}  // namespace

std::string openApiDocument(const std::string& version) {
  Schemas schemas;
  json paths = json::object();
  for (const RestOperation& op : restOperations()) {
    std::string method = op.method;
    for (char& c : method) c = char(std::tolower((unsigned char)c));
    paths[op.path][method] = operationOf(op, schemas);
  }
  json components{{"schemas", schemas.take()},
                  {"securitySchemes", {{"bearer", {{"type", "http"}, {"scheme", "bearer"}}}}}};
  components["schemas"]["Error"] = {
      {"type", "object"},
      {"required", {"error"}},
      {"properties",
       {{"error",
         {{"type", "object"},
          {"required", {"code", "status", "message"}},
          {"properties",
           {{"code", {{"type", "integer"}, {"description", "the HTTP status"}}},
            {"status", {{"type", "string"}, {"description", "the gRPC status name, e.g. NOT_FOUND"}}},
            {"message", {{"type", "string"}}}}}}}}}};
  json document{
      {"openapi", "3.0.3"},
      {"info",
       {{"title", "lensfarm coordinator HTTP API"},
        {"version", version},
        {"description",
         "Every lensfarm.v1.ClientService call over HTTP/JSON (docs/api.md). Bodies and answers are the proto "
         "messages in the protobuf JSON mapping: field names as in the proto, 64-bit integers as strings, enums by "
         "name, bytes as base64. Send the client token (or a user's) as `Authorization: Bearer TOKEN`."}}},
      {"servers", json::array({{{"url", "/"}}})},
      {"security", json::array({{{"bearer", json::array()}}})},
      {"paths", paths},
      {"components", components}};
  return document.dump(2) + "\n";
}

}  // namespace lensfarm
