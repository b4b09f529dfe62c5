#pragma once
// Image files. EXR holds linear radiance (float32 RGB) and the render's provenance in its header;
// PNG holds the exposed, tone-mapped sRGB preview. Both are written atomically (a reader never
// sees a partial file) and a failure throws InputError naming the file.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "film/sensor.h"
#include "scene/scene.h"

namespace lensfarm {

// Header attributes written to every EXR, under the "lensfarm/" prefix.
struct ImageMetadata {
  uint64_t samplesPerPixel = 0;
  uint64_t totalSamples = 0;
  double renderSeconds = 0.0;
  std::string sceneHash;
  std::string rendererVersion;
  std::map<std::string, std::string> extra;  // further string attributes
};

// The files' bytes, in memory (snapshots are served from these).
std::string encodeExr(const Image& image, const ImageMetadata& metadata);
std::string encodePng(const Image& image, const ExposureSettings& exposure);

void writeExr(const std::filesystem::path& path, const Image& image, const ImageMetadata& metadata);
Image readExr(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);
Image decodeExr(const std::string& bytes, ImageMetadata* metadata = nullptr);

void writePng(const std::filesystem::path& path, const Image& image, const ExposureSettings& exposure);

// Writes `bytes` to `path` atomically; throws InputError naming `path` on failure.
void writeBytesAtomically(const std::filesystem::path& path, const std::string& bytes);

// Writes `image` to every path, by extension (.exr or .png); throws InputError for any other.
void writeImageFile(const std::filesystem::path& path, const Image& image, const ImageMetadata& metadata,
                    const ExposureSettings& exposure);

}  // namespace lensfarm
