#pragma once
// Content hashes (SHA-256, via OpenSSL) for scenes and their assets.
#include <string>
#include <string_view>

namespace lensfarm {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(std::string_view bytes);
  std::string hexDigest();  // finishes the hash

 private:
  void* ctx_;
};

std::string sha256Hex(std::string_view bytes);

}  // namespace lensfarm
