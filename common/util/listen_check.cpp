#include "common/util/listen_check.h"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace lensfarm {

std::optional<std::string> listenProblem(const std::string& address) {
  // A malformed address is the flag's own check to name (it says what form it expects).
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos) return std::nullopt;
  std::string host = address.substr(0, colon);
  const std::string port = address.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoi(port) > 65535)
    return std::nullopt;
  if (port == "0" || port == "00" || std::stoi(port) == 0) return std::nullopt;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.empty() || host == "*" ? nullptr : host.c_str(), port.c_str(), &hints, &found) != 0 || !found)
    return "the host \"" + host + "\" does not resolve to an address of this machine";
  std::optional<std::string> problem;
  for (addrinfo* a = found; a; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    const int result = bind(fd, a->ai_addr, a->ai_addrlen);
    const int error = errno;
    close(fd);
    if (result == 0) {
      problem.reset();
      break;
    }
    if (error == EADDRINUSE)
      problem = "the port " + port +
                " is in use: another process (another coordinator?) listens there; stop it, or "
                "give another port (port 0 picks a free one)";
    else if (error == EACCES)
      problem =
          "listening on port " + port + " is not permitted (ports below 1024 need privileges); give a port above 1023";
    else if (error == EADDRNOTAVAIL)
      problem = "\"" + host +
                "\" is not an address of this machine (give 0.0.0.0 for every interface, 127.0.0.1 for this "
                "machine only)";
    else
      problem = std::string("cannot listen there: ") + std::strerror(error);
  }
  freeaddrinfo(found);
  return problem;
}

}  // namespace lensfarm
