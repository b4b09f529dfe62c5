#pragma once
// Where an animation's completed frames live (docs/farm.md "Animation"): one float OpenEXR per
// frame, jobs/<id>/frame-<index>.exr under the state dir (beside state_store.h's files), or under
// a private temporary directory when the coordinator keeps no state (removed with it). Each file
// is written atomically and durably (util/atomic_file.h) before the frame's unit files are
// dropped, so a frame is either stored whole or rebuilt from the ledger after a SIGKILL.
// EXR floats hold the image's floats exactly: a stored frame reads back bit for bit.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>

#include "common/film/image.h"
#include "common/film/image_io.h"

namespace lensfarm {

class FrameStore {
 public:
  // `root`: the state dir; empty: a temporary directory made on first write.
  explicit FrameStore(std::filesystem::path root);
  ~FrameStore();
  FrameStore(const FrameStore&) = delete;
  FrameStore& operator=(const FrameStore&) = delete;

  void write(const std::string& jobId, uint64_t frameIndex, const Image& image, const ImageMetadata& metadata);
  bool has(const std::string& jobId, uint64_t frameIndex) const;
  // What is wrong with the stored frame's file (checked_file.h: its SHA-256 kept beside it), or
  // nullopt when it is sound or not stored.
  std::optional<std::string> damage(const std::string& jobId, uint64_t frameIndex) const;
  // nullopt when the frame is not stored; std::runtime_error when its file cannot be read or is
  // damaged.
  std::optional<Image> read(const std::string& jobId, uint64_t frameIndex, ImageMetadata* metadata = nullptr) const;
  // The frames of the job stored, by index.
  std::set<uint64_t> storedFrames(const std::string& jobId) const;
  // Removes every frame of the job (a deleted job).
  void removeJob(const std::string& jobId);
  std::filesystem::path pathOf(const std::string& jobId, uint64_t frameIndex) const;

 private:
  std::filesystem::path root_;
  bool temporary_ = false;
};

}  // namespace lensfarm
