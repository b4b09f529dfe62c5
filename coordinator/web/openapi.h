#pragma once
// The OpenAPI 3.0 document of the HTTP API (rest_api.h): its paths from restOperations(), its
// schemas from the lensfarm.v1 descriptors in the protobuf JSON mapping (field names as in the
// proto, 64-bit integers as strings, enums by name, bytes as base64), so it cannot drift from the
// proto. docs/api/openapi.json is this document (a test checks it).
#include <string>

namespace lensfarm {

// JSON text; `version`: its info.version.
std::string openApiDocument(const std::string& version);

}  // namespace lensfarm
