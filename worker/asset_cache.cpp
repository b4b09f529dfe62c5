#include "worker/asset_cache.h"
#include "common/util/file_contents.h"

#include <spdlog/spdlog.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/film/image_io.h"
#include "common/util/hash.h"

namespace lensfarm {

namespace fs = std::filesystem;

AssetCache::AssetCache(fs::path dir) : dir_(std::move(dir)) {
  if (!dir_.empty()) fs::create_directories(dir_);
}

std::string AssetCache::get(const std::string& sha256, const std::function<std::string(const std::string&)>& fetch) {
  std::lock_guard lock(mutex_);
  if (auto it = memory_.find(sha256); it != memory_.end()) return it->second;
  if (!dir_.empty()) {
    if (auto bytes = readWholeFile(dir_ / sha256); bytes && sha256Hex(*bytes) == sha256)
      return memory_[sha256] = std::move(*bytes);
  }
  ++fetches_;
  std::string bytes = fetch(sha256);
  const std::string actual = sha256Hex(bytes);
  if (actual != sha256) throw CorruptAsset("asset " + sha256 + " arrived corrupted (hash " + actual + ")");
  if (!dir_.empty()) {
    try {
      writeBytesAtomically(dir_ / sha256, bytes);
    } catch (const std::exception& e) {
      // A full or read-only disk costs this worker a re-fetch later, never the job.
      spdlog::warn("cannot cache asset {}: {}", sha256.substr(0, 12), e.what());
    }
  }
  return memory_[sha256] = std::move(bytes);
}

}  // namespace lensfarm
