#include "common/render/build_identity.h"

#include <embree3/rtcore_config.h>
#include <gnu/libc-version.h>

#include <fstream>

namespace lensfarm {

namespace {

std::string compiler() {
#if defined(__clang__)
  return "clang " __clang_version__;
#elif defined(__GNUC__)
  return "gcc " __VERSION__;
#else
  return "unknown compiler";
#endif
}

std::string architecture() {
#if defined(__x86_64__)
  return "x86_64";
#elif defined(__aarch64__)
  return "aarch64";
#else
  return "other";
#endif
}

}  // namespace

const std::string& buildIdentity() {
  static const std::string id = compiler() + " " + LENSFARM_BUILD_TYPE + ", Embree " + RTC_VERSION_STRING + ", glibc " +
                                gnu_get_libc_version() + ", " + architecture();
  return id;
}

const std::string& cpuModel() {
  static const std::string model = [] {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("model name", 0) == 0 || line.rfind("Model", 0) == 0) {
        const size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        const size_t b = line.find_first_not_of(" \t", colon + 1);
        return b == std::string::npos ? std::string() : line.substr(b);
      }
    return std::string();
  }();
  return model;
}

}  // namespace lensfarm
