#pragma once
// Assets by content hash, on disk under `dir` (files named by their SHA-256) or in memory when
// `dir` is empty. Workers share no file system with clients or the coordinator: every asset is
// fetched once by hash and verified before it is used.
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>

namespace lensfarm {

class AssetCache {
 public:
  explicit AssetCache(std::filesystem::path dir = {});

  // The asset's bytes, from the cache or else from `fetch` (then verified and stored).
  // Throws std::runtime_error if the fetched bytes do not match the hash.
  std::string get(const std::string& sha256, const std::function<std::string(const std::string&)>& fetch);
  uint64_t fetches() const { return fetches_; }  // how many times `fetch` was called

 private:
  std::filesystem::path dir_;
  std::mutex mutex_;
  std::map<std::string, std::string> memory_;
  uint64_t fetches_ = 0;
};

}  // namespace lensfarm
