#pragma once
// Assets by content hash, on disk under `dir` (files named by their SHA-256) or in memory when
// `dir` is empty. Workers share no file system with clients or the coordinator: every asset is
// fetched once by hash and verified before it is used.
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>

namespace lensfarm {

// Fetched bytes that do not match their hash (a transfer went wrong): fetch again.
class CorruptAsset : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class AssetCache {
 public:
  explicit AssetCache(std::filesystem::path dir = {});

  // The asset's bytes, from the cache or else from `fetch` (then verified and stored; a cache
  // that cannot be written is logged and skipped). Throws CorruptAsset if the fetched bytes do
  // not match the hash. `dir` is created by the constructor (std::filesystem errors if it cannot).
  std::string get(const std::string& sha256, const std::function<std::string(const std::string&)>& fetch);
  uint64_t fetches() const { return fetches_; }  // how many times `fetch` was called

 private:
  std::filesystem::path dir_;
  std::mutex mutex_;
  std::map<std::string, std::string> memory_;
  uint64_t fetches_ = 0;
};

}  // namespace lensfarm
