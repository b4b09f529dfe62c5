#pragma once
// Checking a service's listening address before the server library tries it, so that a port in
// use or a malformed address is one sentence naming the flag, not a library's log line.
#include <optional>
#include <string>

namespace lensfarm {

// Why a TCP server cannot listen on `address` (HOST:PORT, [IPV6]:PORT), as a sentence, or
// nothing: the host does not resolve to a local address, or binding fails (in use: "another
// process listens there"; not permitted: a port below 1024). A malformed address is not judged
// here: the flag's own check names it.
// Port 0 (a free port) is never in use. Binding sets SO_REUSEADDR, as gRPC and the HTTP servers
// do, so a port whose connections are closing (TIME_WAIT) is not reported as in use.
std::optional<std::string> listenProblem(const std::string& address);

}  // namespace lensfarm
