#pragma once
// Image files written in memory for the texture and model tests: PNG (8-bit through
// stb_image_write, 16-bit through libpng), JPEG and Radiance HDR (stb_image_write), and the
// CRC that a hand-edited PNG chunk needs.
#include <png.h>
#include <stb/stb_image_write.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace lensfarm::test {

inline void appendToString(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
}

// An 8-bit PNG of `channels` (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA) per pixel, rows top first.
inline std::string png8(int width, int height, int channels, const std::vector<uint8_t>& pixels) {
  std::string out;
  if (!stbi_write_png_to_func(appendToString, &out, width, height, channels, pixels.data(), width * channels))
    throw std::runtime_error("stbi_write_png_to_func failed");
  return out;
}

inline std::string jpeg(int width, int height, int channels, const std::vector<uint8_t>& pixels, int quality = 100) {
  std::string out;
  if (!stbi_write_jpg_to_func(appendToString, &out, width, height, channels, pixels.data(), quality))
    throw std::runtime_error("stbi_write_jpg_to_func failed");
  return out;
}

inline std::string hdr(int width, int height, int channels, const std::vector<float>& pixels) {
  std::string out;
  if (!stbi_write_hdr_to_func(appendToString, &out, width, height, channels, pixels.data()))
    throw std::runtime_error("stbi_write_hdr_to_func failed");
  return out;
}

// A 16-bit PNG through libpng (stb_image_write writes 8 bits only). colorType: PNG_COLOR_TYPE_GRAY,
// _GRAY_ALPHA, _RGB or _RGBA; `samples` in that order, rows top first.
inline std::string png16(int width, int height, int colorType, const std::vector<uint16_t>& samples) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  std::string out;
  std::vector<uint8_t> bytes(2 * samples.size());
  for (size_t k = 0; k < samples.size(); ++k) {  // PNG stores 16-bit samples big-endian
    bytes[2 * k] = uint8_t(samples[k] >> 8);
    bytes[2 * k + 1] = uint8_t(samples[k] & 0xFF);
  }
  const size_t rowBytes = bytes.size() / size_t(height);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng failed");
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t size) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), size);
      },
      nullptr);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 16, colorType, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y) png_write_row(png, bytes.data() + size_t(y) * rowBytes);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

// The CRC-32 of PNG chunks (ISO 3309, as the PNG specification's annex gives it).
inline uint32_t pngCrc(const std::string& bytes, size_t from, size_t count) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t k = from; k < from + count; ++k) {
    crc ^= uint8_t(bytes[k]);
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

inline void putBigEndian32(std::string& bytes, size_t at, uint32_t value) {
  for (int k = 0; k < 4; ++k) bytes[at + size_t(k)] = char(uint8_t(value >> (24 - 8 * k)));
}

// `png` with its IHDR saying width x height (and a correct CRC), its pixel data unchanged.
inline std::string withPngSize(std::string png, uint32_t width, uint32_t height) {
  // Signature (8), IHDR length (4), "IHDR" (4), width (4), height (4), ..., CRC after 13 bytes.
  putBigEndian32(png, 16, width);
  putBigEndian32(png, 20, height);
  putBigEndian32(png, 8 + 8 + 13, pngCrc(png, 12, 4 + 13));
  return png;
}

}  // namespace lensfarm::test
