#pragma once
// A finished job's final image, kept after its film (Accumulator) is freed: the job's developed
// image (float32 linear RGB, the diffraction PSF applied, as Coordinator::image made it) and its
// EXR metadata. With a state dir it is the file jobs/<id>/final.exr, written atomically (temp
// file, fsync, rename: film/image_io.h); without one, the encoded EXR bytes are held in memory.
// OpenEXR's FLOAT channels with its default (ZIP, lossless) compression give back the same bits.
// The file's SHA-256 is kept beside it (checked_file.h, "final.exr.sha256") and checked before
// it is read or streamed: a damaged archive is one error naming the file, never another image.
//
// Used by the job life cycle (lifecycle.cpp, docs/farm.md "Job life cycle"): archiving stores the
// image, Download and snapshots load it, deleting the job removes it.
#include <filesystem>
#include <istream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "common/film/image.h"
#include "common/film/image_io.h"

namespace lensfarm {

class JobArchive {
 public:
  // `stateDir` empty: images held in memory.
  explicit JobArchive(std::filesystem::path stateDir);

  // Stores the job's final image (replacing any earlier one); durable on return with a state dir.
  void store(const std::string& jobId, const Image& image, const ImageMetadata& metadata);
  // The image as stored, with its metadata; nullopt if none was stored (or its file is missing);
  // FarmError kFailedPrecondition naming the file if it does not match its checksum.
  std::optional<Image> load(const std::string& jobId, ImageMetadata* metadata = nullptr) const;
  // With a state dir, the stored file opened for reading (its bytes are what encodeExr gives for
  // the image and metadata load() returns), with its `size`; null without one or if it is missing.
  // Open, it stays readable if the job is deleted meanwhile.
  std::unique_ptr<std::istream> open(const std::string& jobId, uint64_t* size) const;
  // Forgets the job's image (and removes its file).
  void remove(const std::string& jobId);
  // Where the image of `jobId` is kept with a state dir (empty without one).
  std::filesystem::path pathOf(const std::string& jobId) const;
  // Bytes held in memory (the encoded images without a state dir; 0 with one).
  uint64_t bytesInMemory() const;
  uint64_t bytesInMemoryOf(const std::string& jobId) const;

 private:
  void check(const std::string& jobId) const;  // the file against its checksum; FarmError naming it
  const std::filesystem::path dir_;
  mutable std::mutex mutex_;
  std::map<std::string, std::string> inMemory_;  // job id -> EXR bytes (no state dir)
};

}  // namespace lensfarm
