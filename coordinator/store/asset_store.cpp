// AssetStore: assets by SHA-256, the checks on uploads and queries, and their counts
// (asset_store.h).
#include "coordinator/store/asset_store.h"

#include <algorithm>
#include <optional>
#include <set>

#include "common/farm/farm_types.h"
#include "common/util/byte_size.h"
#include "common/util/hash.h"
#include "coordinator/store/state_store.h"

namespace lensfarm {

namespace {
bool isSha256Hex(const std::string& text) {
  return text.size() == 64 &&
         std::all_of(text.begin(), text.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

// A client's string in an error message: at most 80 characters, control characters as '?'.
std::string shown(const std::string& text) {
  std::string out = text.substr(0, 80);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return text.size() > 80 ? out + "..." : out;
}
}  // namespace

void AssetStore::checkSha256(const std::string& sha256, const std::string& field) {
  if (!isSha256Hex(sha256))
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    field + ": \"" + shown(sha256) + "\" is not a SHA-256 (64 lowercase hex digits)");
}

void AssetStore::restore(StateStore& store) {
  auto listed = store.listAssets();
  std::lock_guard lock(mutex_);
  store_ = &store;
  onDisk_ = std::move(listed);
}

bool AssetStore::has(const std::string& sha256) const {
  std::lock_guard lock(mutex_);
  return assets_.count(sha256) > 0 || onDisk_.count(sha256) > 0;
}

bool AssetStore::put(const std::string& sha256, std::string bytes) {
  checkSha256(sha256, "sha256");
  bytesReceived_ += bytes.size();
  const std::string actual = sha256Hex(bytes);
  if (actual != sha256)
    throw FarmError(FarmError::Kind::kInvalidArgument,
                    "asset " + sha256 + ": the uploaded bytes hash to " + actual + " (corrupted upload?)");
  if (uploadFindsPresent(sha256)) return false;
  checkRoom(sha256, bytes.size());
  if (store_) store_->putAsset(sha256, bytes);
  std::lock_guard lock(mutex_);
  const bool stored = store_ ? onDisk_.emplace(sha256, bytes.size()).second
                             : assets_.emplace(sha256, std::make_shared<const std::string>(std::move(bytes))).second;
  ++(stored ? uploadsStored_ : uploadsPresent_);  // two uploads of it at once: one stored
  return stored;
}

std::map<std::string, uint64_t> AssetStore::sizes() const {
  std::lock_guard lock(mutex_);
  std::map<std::string, uint64_t> out = onDisk_;
  for (const auto& [sha, bytes] : assets_) out[sha] = bytes->size();
  return out;
}

uint64_t AssetStore::sizeOf(const std::string& sha256) const {
  std::lock_guard lock(mutex_);
  if (const auto it = assets_.find(sha256); it != assets_.end()) return it->second->size();
  const auto it = onDisk_.find(sha256);
  return it == onDisk_.end() ? 0 : it->second;
}

void AssetStore::remove(const std::string& sha256) {
  uint64_t size = 0;
  bool onDisk = false;
  {
    std::lock_guard lock(mutex_);
    if (const auto it = assets_.find(sha256); it != assets_.end()) {
      size = it->second->size();
      assets_.erase(it);
    } else if (const auto disk = onDisk_.find(sha256); disk != onDisk_.end()) {
      size = disk->second;
      onDisk = true;
      onDisk_.erase(disk);
      inUse_.erase(sha256);
    } else {
      return;
    }
  }
  if (onDisk) store_->removeAsset(sha256);
  ++collected_;
  collectedBytes_ += size;
}

uint64_t AssetStore::storedBytes() const {
  std::lock_guard lock(mutex_);
  uint64_t total = 0;
  for (const auto& [sha, bytes] : assets_) total += bytes->size();
  for (const auto& [sha, size] : onDisk_) total += size;
  return total;
}

void AssetStore::checkRoom(const std::string& sha256, uint64_t bytes) const {
  const uint64_t quota = quota_, stored = quota ? storedBytes() : 0;
  if (quota && (bytes > quota || stored > quota - bytes))
    throw FarmError(FarmError::Kind::kResourceExhausted, "asset " + sha256.substr(0, 12) + " (" + formatBytes(bytes) +
                                                             ") does not fit: the coordinator keeps " +
                                                             formatBytes(stored) + " of assets, at most " +
                                                             formatBytes(quota) + " (--max-asset-bytes)");
}

bool AssetStore::uploadFindsPresent(const std::string& sha256) {
  std::lock_guard lock(mutex_);
  if (!assets_.count(sha256) && !onDisk_.count(sha256)) return false;
  ++uploadsPresent_;
  return true;
}

std::vector<std::string> AssetStore::missing(const std::vector<std::string>& sha256s) const {
  if (sha256s.size() > kMaxQuery)
    throw FarmError(FarmError::Kind::kInvalidArgument, std::to_string(sha256s.size()) +
                                                           " hashes in one query; at most " +
                                                           std::to_string(kMaxQuery) + " (ask in batches)");
  for (size_t i = 0; i < sha256s.size(); ++i) checkSha256(sha256s[i], "sha256[" + std::to_string(i) + "]");
  std::vector<std::string> out;
  std::set<std::string> seen;
  std::lock_guard lock(mutex_);
  for (const std::string& sha : sha256s)
    if (!assets_.count(sha) && !onDisk_.count(sha) && seen.insert(sha).second) out.push_back(sha);
  return out;
}

std::shared_ptr<const std::string> AssetStore::find(const std::string& sha256) const {
  {
    std::lock_guard lock(mutex_);
    if (auto it = assets_.find(sha256); it != assets_.end()) return it->second;
    if (!onDisk_.count(sha256)) return nullptr;
    if (auto it = inUse_.find(sha256); it != inUse_.end())
      if (auto bytes = it->second.lock()) return bytes;
  }
  // Read outside the lock; two readers at once may both read it, and share the first one kept.
  std::optional<std::string> read = store_->loadAsset(sha256);
  if (!read || sha256Hex(*read) != sha256) {
    store_->setAssetAside(sha256, read ? "its bytes no longer hash to its name" : "unreadable");
    std::lock_guard lock(mutex_);
    onDisk_.erase(sha256);
    return nullptr;
  }
  auto bytes = std::make_shared<const std::string>(std::move(*read));
  std::lock_guard lock(mutex_);
  std::weak_ptr<const std::string>& slot = inUse_[sha256];
  if (auto kept = slot.lock()) return kept;
  slot = bytes;
  return bytes;
}

uint64_t AssetStore::residentBytes() const {
  std::lock_guard lock(mutex_);
  uint64_t bytes = 0;
  for (const auto& [sha, held] : assets_) bytes += held->size();
  for (auto it = inUse_.begin(); it != inUse_.end();) {
    if (auto held = it->second.lock()) {
      bytes += held->size();
      ++it;
    } else {
      it = inUse_.erase(it);
    }
  }
  return bytes;
}

std::shared_ptr<const std::string> AssetStore::get(const std::string& sha256) const {
  std::shared_ptr<const std::string> bytes = find(sha256);
  if (!bytes) throw FarmError(FarmError::Kind::kNotFound, "no asset " + sha256);
  return bytes;
}

std::shared_ptr<const std::string> AssetStore::send(const std::string& sha256) {
  std::shared_ptr<const std::string> bytes = get(sha256);
  ++sent_;
  return bytes;
}

AssetStore::Counts AssetStore::counts() const {
  return Counts{bytesReceived_, uploadsStored_, uploadsPresent_, sent_, collected_, collectedBytes_};
}

}  // namespace lensfarm
