#pragma once
// Image files. EXR holds linear radiance (float32 RGB) and the render's provenance in its header;
// PNG holds the exposed, tone-mapped sRGB preview. Both are written atomically (a reader never
// sees a partial file) and a failure throws InputError naming the file.
//
// Both are lossless whatever the compression: an EXR decodes to the very floats it was given, a
// PNG to the very bytes exposeToSrgb8 made. The compression only trades time for size
// (docs/performance.md "Everything around the render"): PNGs are deflated with zlib's run-length
// strategy at level 1 after an Up filter (about 10x faster than libpng's default of level 6 with
// every filter tried per row, and within a few % of its size on rendered images).
#include <cstdint>
#include <filesystem>
#include <map>
#include <ostream>
#include <string>

#include "common/film/exposure.h"
#include "common/film/sensor.h"

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

// How an EXR's pixels are compressed; both lossless. ZIP (zlib on blocks of 16 scanlines) for
// files that are kept or sent (the farm's archive, frames and downloads); none where size does
// not matter and time does (`lensfarm render`'s outputs by default): at 1080p, ZIP costs about a
// second on one core to save 7 % of a 1-spp image's 25 MB, and little more on a converged one.
enum class ExrCompression { kNone, kZip };

// The files' bytes, in memory (snapshots are served from these).
std::string encodeExr(const Image& image, const ImageMetadata& metadata,
                      ExrCompression compression = ExrCompression::kZip);
std::string encodePng(const Image& image, const ExposureSettings& exposure);

void writeExr(const std::filesystem::path& path, const Image& image, const ImageMetadata& metadata,
              ExrCompression compression = ExrCompression::kZip);
// The same bytes into a seekable stream (a download's spool file), a few scanlines at a time.
void writeExr(std::ostream& out, const Image& image, const ImageMetadata& metadata,
              ExrCompression compression = ExrCompression::kZip);
Image readExr(const std::filesystem::path& path, ImageMetadata* metadata = nullptr);
Image decodeExr(const std::string& bytes, ImageMetadata* metadata = nullptr);

void writePng(const std::filesystem::path& path, const Image& image, const ExposureSettings& exposure);

// Writes `bytes` to `path` atomically; throws InputError naming `path` on failure.
void writeBytesAtomically(const std::filesystem::path& path, const std::string& bytes);

// Writes `image` to every path, by extension (.exr or .png); throws InputError for any other.
void writeImageFile(const std::filesystem::path& path, const Image& image, const ImageMetadata& metadata,
                    const ExposureSettings& exposure, ExrCompression compression = ExrCompression::kZip);

}  // namespace lensfarm
