#pragma once
// The coordinator's content-addressed asset store: the bytes of every uploaded asset by their
// SHA-256, in memory or, with a state dir, in StateStore's assets/. It checks what clients
// upload and ask about, and counts what the metrics show. No network code.
//
// With a state dir the bytes live on disk, not in memory: the store keeps each asset's size, and
// an asset's bytes are read when someone needs them (a job's scene is loaded, a worker fetches it)
// and shared while anyone holds them, then freed, so uploaded assets cost the coordinator no
// memory for its life and a restart loads none of them. An asset read from disk is checked
// against its hash: a damaged file is kept aside (lost+found/) and the asset counts as missing,
// so the next client that needs it uploads it again.
//
// Invariants:
//  - An asset is stored only under the hash of its bytes, and never replaced. It is removed only
//    by remove(), which the Coordinator calls for an asset no job refers to (asset garbage
//    collection, docs/farm.md "Assets"), so a job's assets stay readable for as long as the job is.
//  - With a state store, an asset is durable before it is listed.
//  - Thread-safe: its own lock, held only around the maps (never while taking another, nor while
//    reading a file).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace lensfarm {

class StateStore;

class AssetStore {
 public:
  // The most hashes one missing() call takes (FindMissingAssets: 50000 hashes are ~3.3 MB,
  // within gRPC's 4 MiB message limit).
  static constexpr size_t kMaxQuery = 50000;

  // A SHA-256 as every call takes it: 64 lowercase hex digits (uppercase is refused, never folded,
  // so one asset has one name). Throws FarmError(kInvalidArgument) naming `field`:
  // `sha256[3]: "..." is not a SHA-256 (64 lowercase hex digits)`.
  static void checkSha256(const std::string& sha256, const std::string& field);

  // Lists the assets saved in `store` (their bytes stay on disk), which keeps every new one from
  // now on.
  void restore(StateStore& store);

  bool has(const std::string& sha256) const;
  // Those of `sha256s` that are not stored, in their order, each once. FarmError(kInvalidArgument)
  // for more than kMaxQuery hashes, or naming the first that is not 64 lowercase hex digits by
  // its index ("sha256[3]").
  std::vector<std::string> missing(const std::vector<std::string>& sha256s) const;
  // Stores bytes under their hash; throws FarmError(kInvalidArgument) if the hash is not one
  // (checkSha256) or the bytes do not match it. Returns false if the asset was already present.
  bool put(const std::string& sha256, std::string bytes);
  // An upload of `sha256` has begun: true if the asset is stored already (counted like a put()
  // that found it present).
  bool uploadFindsPresent(const std::string& sha256);
  // The asset's bytes; null if it is not stored.
  std::shared_ptr<const std::string> find(const std::string& sha256) const;
  // The asset's bytes; FarmError(kNotFound) if it is not stored.
  std::shared_ptr<const std::string> get(const std::string& sha256) const;
  // get() for a worker, counted in Counts::sent.
  std::shared_ptr<const std::string> send(const std::string& sha256);

  // Every stored asset and its size in bytes.
  std::map<std::string, uint64_t> sizes() const;
  // The asset's size; 0 if it is not stored.
  uint64_t sizeOf(const std::string& sha256) const;
  // Forgets the asset and removes its bytes (its file, with a state dir); holders of its bytes
  // keep them. Counted in Counts::collected.
  void remove(const std::string& sha256);

  // Counted since this process started (MetricsSnapshot).
  struct Counts {
    uint64_t bytesReceived = 0;                  // asset bytes uploaded (read in full)
    uint64_t uploadsStored = 0;                  // uploads of assets new to the store
    uint64_t uploadsPresent = 0;                 // uploads of assets it held already
    uint64_t sent = 0;                           // assets sent to workers
    uint64_t collected = 0, collectedBytes = 0;  // removed by the garbage collection
  };
  Counts counts() const;

  // Bytes of assets held in memory now: all of them without a state dir, else those in use.
  uint64_t residentBytes() const;
  // Bytes of every asset kept, in memory or on disk.
  uint64_t storedBytes() const;
  // The most bytes of assets kept (--max-asset-bytes; 0: no limit). An asset that would pass it is
  // refused, FarmError(kResourceExhausted) naming both: checkRoom() on an upload's declared size
  // before its bytes are read, and put() again.
  void setQuota(uint64_t bytes) { quota_ = bytes; }
  void checkRoom(const std::string& sha256, uint64_t bytes) const;

 private:
  StateStore* store_ = nullptr;  // null: in memory only
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const std::string>> assets_;  // without a store; guarded by mutex_
  // With a store: the sizes of those on disk (a damaged one found by find() leaves); guarded by mutex_.
  mutable std::map<std::string, uint64_t> onDisk_;
  mutable std::map<std::string, std::weak_ptr<const std::string>> inUse_;  // with a store; guarded by mutex_
  std::atomic<uint64_t> bytesReceived_{0}, uploadsStored_{0}, uploadsPresent_{0}, sent_{0};
  std::atomic<uint64_t> collected_{0}, collectedBytes_{0};
  std::atomic<uint64_t> quota_{0};
};

}  // namespace lensfarm
