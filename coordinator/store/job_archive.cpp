#include "coordinator/store/job_archive.h"

#include <fstream>

#include "common/farm/farm_types.h"
#include "coordinator/store/checked_file.h"

namespace lensfarm {

namespace fs = std::filesystem;

JobArchive::JobArchive(fs::path stateDir) : dir_(std::move(stateDir)) {}

fs::path JobArchive::pathOf(const std::string& jobId) const {
  return dir_.empty() ? fs::path() : dir_ / "jobs" / jobId / "final.exr";
}

void JobArchive::store(const std::string& jobId, const Image& image, const ImageMetadata& metadata) {
  if (dir_.empty()) {
    std::string bytes = encodeExr(image, metadata);
    std::lock_guard lock(mutex_);
    inMemory_[jobId] = std::move(bytes);
    return;
  }
  fs::create_directories(pathOf(jobId).parent_path());
  std::error_code ignored;
  fs::remove(sidecarOf(pathOf(jobId)), ignored);  // an earlier image's checksum must not judge this one
  // Straight from the image into a temp file, fsync, rename (util/atomic_file.h): no encoded copy.
  writeExr(pathOf(jobId), image, metadata);
  writeChecksumSidecar(pathOf(jobId));
}

void JobArchive::check(const std::string& jobId) const {
  // The file named inside the state dir: a client is not told where the state dir is.
  if (const std::optional<std::string> damage = checkChecksumSidecar(pathOf(jobId)))
    throw FarmError(FarmError::Kind::kFailedPrecondition,
                    jobId + "'s archived image (jobs/" + jobId + "/final.exr in the state dir) is damaged: " + *damage +
                        "; its film was freed when it was archived, so the image is lost (lensfarm delete " + jobId +
                        ")");
}

std::unique_ptr<std::istream> JobArchive::open(const std::string& jobId, uint64_t* size) const {
  if (dir_.empty() || !fs::exists(pathOf(jobId))) return nullptr;
  check(jobId);
  auto in = std::make_unique<std::ifstream>(pathOf(jobId), std::ios::binary | std::ios::ate);
  if (!*in) return nullptr;
  *size = uint64_t(in->tellg());
  in->seekg(0);
  return in;
}

std::optional<Image> JobArchive::load(const std::string& jobId, ImageMetadata* metadata) const {
  if (dir_.empty()) {
    std::lock_guard lock(mutex_);
    const auto it = inMemory_.find(jobId);
    if (it == inMemory_.end()) return std::nullopt;
    return decodeExr(it->second, metadata);
  }
  if (!fs::exists(pathOf(jobId))) return std::nullopt;
  check(jobId);
  return readExr(pathOf(jobId), metadata);
}

void JobArchive::remove(const std::string& jobId) {
  if (dir_.empty()) {
    std::lock_guard lock(mutex_);
    inMemory_.erase(jobId);
    return;
  }
  std::error_code ignored;
  fs::remove(pathOf(jobId), ignored);
  fs::remove(sidecarOf(pathOf(jobId)), ignored);
}

uint64_t JobArchive::bytesInMemoryOf(const std::string& jobId) const {
  std::lock_guard lock(mutex_);
  const auto it = inMemory_.find(jobId);
  return it == inMemory_.end() ? 0 : it->second.size();
}

uint64_t JobArchive::bytesInMemory() const {
  std::lock_guard lock(mutex_);
  uint64_t total = 0;
  for (const auto& [id, bytes] : inMemory_) total += bytes.size();
  return total;
}

}  // namespace lensfarm
