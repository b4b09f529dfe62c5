// FrameStore: completed frames as float OpenEXR files (frame_store.h).
#include "coordinator/store/frame_store.h"

#include <cstdlib>
#include <stdexcept>

#include <system_error>
#include "coordinator/store/checked_file.h"

namespace lensfarm {

namespace fs = std::filesystem;

FrameStore::FrameStore(fs::path root) : root_(std::move(root)) {}

FrameStore::~FrameStore() {
  if (!temporary_) return;
  std::error_code ec;
  fs::remove_all(root_, ec);
}

fs::path FrameStore::pathOf(const std::string& jobId, uint64_t frameIndex) const {
  return root_ / "jobs" / jobId / ("frame-" + std::to_string(frameIndex) + ".exr");
}

void FrameStore::write(const std::string& jobId, uint64_t frameIndex, const Image& image,
                       const ImageMetadata& metadata) {
  if (root_.empty()) {
    std::string pattern = (fs::temp_directory_path() / "lensfarm-frames-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temporary directory for frames");
    root_ = pattern;
    temporary_ = true;
  }
  fs::create_directories(pathOf(jobId, frameIndex).parent_path());
  std::error_code ignored;
  fs::remove(sidecarOf(pathOf(jobId, frameIndex)), ignored);  // an earlier write's must not judge this one
  writeExr(pathOf(jobId, frameIndex), image, metadata);
  writeChecksumSidecar(pathOf(jobId, frameIndex));
}

std::optional<std::string> FrameStore::damage(const std::string& jobId, uint64_t frameIndex) const {
  if (!has(jobId, frameIndex)) return std::nullopt;
  return checkChecksumSidecar(pathOf(jobId, frameIndex));
}

bool FrameStore::has(const std::string& jobId, uint64_t frameIndex) const {
  return !root_.empty() && fs::exists(pathOf(jobId, frameIndex));
}

std::optional<Image> FrameStore::read(const std::string& jobId, uint64_t frameIndex, ImageMetadata* metadata) const {
  if (!has(jobId, frameIndex)) return std::nullopt;
  if (const std::optional<std::string> wrong = damage(jobId, frameIndex))
    throw std::runtime_error(  // named inside the state dir: a client is not told where it is
        "jobs/" + jobId + "/" + pathOf(jobId, frameIndex).filename().string() +
        " in the state dir is damaged: " + *wrong);
  return readExr(pathOf(jobId, frameIndex), metadata);
}

std::set<uint64_t> FrameStore::storedFrames(const std::string& jobId) const {
  std::set<uint64_t> out;
  if (root_.empty()) return out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(root_ / "jobs" / jobId, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("frame-", 0) != 0 || entry.path().extension() != ".exr") continue;
    const std::string digits = name.substr(6, name.size() - 6 - 4);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    out.insert(std::stoull(digits));
  }
  return out;
}

void FrameStore::removeJob(const std::string& jobId) {
  if (root_.empty()) return;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(root_ / "jobs" / jobId, ec))
    if (entry.path().filename().string().rfind("frame-", 0) == 0) fs::remove(entry.path(), ec);
}

}  // namespace lensfarm
