#include "common/texture/image_decode.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <stb_image.h>

#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <string_view>
#include <vector>

#include "common/util/byte_size.h"
#include "common/util/error.h"

namespace lensfarm {

namespace {

enum class Format { kPng, kJpeg, kHdr, kExr, kUnknown };

bool startsWith(const std::string& bytes, std::string_view magic) {
  return bytes.size() >= magic.size() && std::memcmp(bytes.data(), magic.data(), magic.size()) == 0;
}

// Recognised by the first bytes, whatever the file is called: stb_image would also take GIF, BMP,
// TGA (which has no magic: any bytes may pass for one), PSD, PIC and PNM.
Format formatOf(const std::string& bytes) {
  if (startsWith(bytes, "\x89PNG\r\n\x1A\n")) return Format::kPng;
  if (startsWith(bytes, "\xFF\xD8\xFF")) return Format::kJpeg;
  if (startsWith(bytes, "#?RADIANCE") || startsWith(bytes, "#?RGBE")) return Format::kHdr;
  if (startsWith(bytes, std::string_view("\x76\x2F\x31\x01", 4))) return Format::kExr;
  return Format::kUnknown;
}

const char* formatName(Format f) {
  switch (f) {
    case Format::kPng: return "PNG";
    case Format::kJpeg: return "JPEG";
    case Format::kHdr: return "Radiance HDR";
    case Format::kExr: return "EXR";
    default: return "image";
  }
}

std::string firstBytes(const std::string& bytes) {
  if (bytes.empty()) return "the file is empty";
  std::string out = "starts with";
  for (size_t k = 0; k < std::min<size_t>(bytes.size(), 4); ++k) {
    char hex[4];
    std::snprintf(hex, sizeof hex, " %02x", unsigned(static_cast<unsigned char>(bytes[k])));
    out += hex;
  }
  return out;
}

void checkSize(int64_t width, int64_t height, Format f, const std::string& name) {
  if (width < 1 || height < 1 || width > kMaxTextureSide || height > kMaxTextureSide)
    throw InputError(name, std::string(formatName(f)) + " of " + std::to_string(width) + " x " +
                               std::to_string(height) + " pixels: each side must be 1 to " +
                               std::to_string(kMaxTextureSide));
  // What it becomes in memory (float RGBA, and its mip levels, a third more: texture/texture.h)
  // must fit in one job's memory, or decoding it could take the machine down before any
  // estimate refuses the job (farm/memory_estimate.h).
  const uint64_t decoded = uint64_t(width) * uint64_t(height) * 4 * sizeof(float) * 4 / 3;
  const uint64_t budget = defaultJobMemoryBudget();
  if (decoded > budget)
    throw InputError(name, std::string(formatName(f)) + " of " + std::to_string(width) + " x " +
                               std::to_string(height) + " pixels decodes to " + formatBytes(decoded) +
                               " with its mip levels, more than the " + formatBytes(budget) + " allowed per job (" +
                               defaultJobMemoryBudgetSource() +
                               "); lower its resolution, or set LENSFARM_MAX_JOB_MEMORY if this machine can hold it");
}

// Float texels (HDR, EXR) must be finite and non-negative: a texture multiplies radiance.
void checkFloatTexels(const RgbaImage& image, Format f, const std::string& name) {
  for (size_t k = 0; k < image.texels.size(); ++k) {
    const float v = image.texels[k];
    if (std::isfinite(v) && v >= 0.0f) continue;
    const size_t texel = k / 4;
    const int x = int(texel % size_t(image.width)), y = int(texel / size_t(image.width));
    throw InputError(name, std::string(formatName(f)) + " pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                               ") channel " + "RGBA"[k % 4] + " is " +
                               (std::isfinite(v) ? std::to_string(v) : "not finite") +
                               ": texture values must be finite and non-negative");
  }
}

// ---- PNG, JPEG and HDR through stb_image ----

int64_t bigEndian32(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  for (size_t k = 0; k < 4; ++k) v = (v << 8) | uint32_t(static_cast<unsigned char>(bytes[at + k]));
  return int64_t(v);
}

struct StbFree {
  void operator()(void* p) const { stbi_image_free(p); }
};

std::string stbReason() {
  const char* reason = stbi_failure_reason();
  return reason ? reason : "unknown error";
}

// The table of srgbToLinear for the integer values 0..maxValue, built once.
const std::vector<float>& srgbTable(int maxValue) {
  auto build = [](int top) {
    std::vector<float> table(size_t(top) + 1);
    for (int k = 0; k <= top; ++k) table[size_t(k)] = srgbToLinear(float(k) / float(top));
    return table;
  };
  static const std::vector<float> table8 = build(255), table16 = build(65535);
  return maxValue == 255 ? table8 : table16;
}

template <typename T>
void convertIntegers(const T* in, RgbaImage& out, ColorEncoding encoding) {
  constexpr int kMax = sizeof(T) == 1 ? 255 : 65535;
  const std::vector<float>& srgb = srgbTable(kMax);
  for (size_t k = 0; k < out.texels.size(); ++k) {
    const bool colour = encoding == ColorEncoding::kSrgb && k % 4 != 3;  // alpha is always linear
    out.texels[k] = colour ? srgb[in[k]] : float(in[k]) / float(kMax);
  }
}

RgbaImage decodeWithStb(const std::string& bytes, Format format, const std::string& name, ColorEncoding encoding) {
  if (bytes.size() > size_t(INT_MAX))
    throw InputError(name, std::string(formatName(format)) + " file larger than 2 GiB is not supported");
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int len = int(bytes.size());
  const std::string corrupt = std::string("truncated or corrupt ") + formatName(format) + " (stb_image: ";
  // The header first: a size beyond the limit is refused before anything is allocated. A PNG's
  // IHDR is read here, as stb_image's own check of huge sizes would call the file unknown.
  if (format == Format::kPng && bytes.size() >= 24 && bytes.compare(12, 4, "IHDR") == 0)
    checkSize(bigEndian32(bytes, 16), bigEndian32(bytes, 20), format, name);
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(data, len, &width, &height, &channels))
    throw InputError(name, corrupt + stbReason() + ")");
  checkSize(width, height, format, name);

  RgbaImage image;
  image.width = width;
  image.height = height;
  image.texels.resize(4 * size_t(width) * size_t(height));
  int w = 0, h = 0;
  // Four channels asked for: stb_image replicates grey into RGB and adds alpha 1 where there is
  // none. Rows stay top first (the global flip flag is never set: it is not thread-safe).
  if (format == Format::kHdr) {
    std::unique_ptr<float, StbFree> px(stbi_loadf_from_memory(data, len, &w, &h, &channels, 4));
    if (!px) throw InputError(name, corrupt + stbReason() + ")");
    std::memcpy(image.texels.data(), px.get(), image.texels.size() * sizeof(float));
  } else if (stbi_is_16_bit_from_memory(data, len)) {
    std::unique_ptr<stbi_us, StbFree> px(stbi_load_16_from_memory(data, len, &w, &h, &channels, 4));
    if (!px) throw InputError(name, corrupt + stbReason() + ")");
    convertIntegers(px.get(), image, encoding);
  } else {
    std::unique_ptr<stbi_uc, StbFree> px(stbi_load_from_memory(data, len, &w, &h, &channels, 4));
    if (!px) throw InputError(name, corrupt + stbReason() + ")");
    convertIntegers(px.get(), image, encoding);
  }
  if (w != width || h != height) throw InputError(name, corrupt + "size changed between header and pixels)");
  return image;
}

// ---- OpenEXR ----

// The data window from the EXR header, read here so that a crafted size is refused before
// OpenEXR allocates line-offset tables or pixels. Attributes are name\0 type\0 size value.
void checkExrHeader(const std::string& bytes, const std::string& name) {
  const std::string corrupt = "truncated or corrupt EXR (";
  if (bytes.size() < 8) throw InputError(name, corrupt + "no header)");
  const uint32_t flags = uint32_t(static_cast<unsigned char>(bytes[5]));
  if (flags & 0x18)  // bit 11 non-image (deep), bit 12 multi-part
    throw InputError(name, "deep or multi-part EXR files are not supported as textures");
  size_t pos = 8;
  auto cString = [&]() {
    const size_t end = bytes.find('\0', pos);
    if (end == std::string::npos) throw InputError(name, corrupt + "header ends early)");
    std::string s = bytes.substr(pos, end - pos);
    pos = end + 1;
    return s;
  };
  auto int32At = [&](size_t at) {
    uint32_t v = 0;
    for (int k = 3; k >= 0; --k) v = (v << 8) | uint32_t(static_cast<unsigned char>(bytes[at + size_t(k)]));
    return int32_t(v);
  };
  for (;;) {
    const std::string attribute = cString();
    if (attribute.empty()) break;
    const std::string type = cString();
    if (pos + 4 > bytes.size()) throw InputError(name, corrupt + "header ends early)");
    const int32_t size = int32At(pos);
    pos += 4;
    if (size < 0 || pos + size_t(size) > bytes.size()) throw InputError(name, corrupt + "header ends early)");
    if (attribute == "dataWindow" && type == "box2i" && size == 16) {
      const int64_t width = int64_t(int32At(pos + 8)) - int32At(pos) + 1;
      const int64_t height = int64_t(int32At(pos + 12)) - int32At(pos + 4) + 1;
      checkSize(width, height, Format::kExr, name);
      return;
    }
    pos += size_t(size);
  }
  throw InputError(name, corrupt + "no dataWindow in the header)");
}

RgbaImage decodeExrTexture(const std::string& bytes, const std::string& name) {
  checkExrHeader(bytes, name);
  RgbaImage image;
  try {
    Imf::StdISStream stream;
    stream.str(bytes);
    Imf::InputFile file(stream);
    const Imath::Box2i window = file.header().dataWindow();
    image.width = window.max.x - window.min.x + 1;
    image.height = window.max.y - window.min.y + 1;
    image.texels.assign(4 * size_t(image.width) * size_t(image.height), 0.0f);
    const Imf::ChannelList& channels = file.header().channels();
    const bool rgb = channels.findChannel("R") || channels.findChannel("G") || channels.findChannel("B");
    if (!rgb && !channels.findChannel("Y"))
      throw InputError(name, "EXR without R, G, B or Y channels: not an image texture");
    // Slices address pixel (x, y) of the data window at base + x * xStride + y * yStride.
    const size_t xStride = 4 * sizeof(float), yStride = xStride * size_t(image.width);
    char* origin = reinterpret_cast<char*>(image.texels.data()) -
                   (ptrdiff_t(window.min.x) * ptrdiff_t(xStride) + ptrdiff_t(window.min.y) * ptrdiff_t(yStride));
    Imf::FrameBuffer fb;
    // Missing colour channels read 0, missing alpha 1; a luminance-only file fills R (then G, B).
    const char* names[4] = {rgb ? "R" : "Y", "G", "B", "A"};
    for (int c = 0; c < 4; ++c) {
      if (c > 0 && c < 3 && !rgb) continue;
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, origin + c * ptrdiff_t(sizeof(float)), xStride, yStride, 1, 1,
                                     c == 3 ? 1.0 : 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(window.min.y, window.max.y);
    if (!rgb)
      for (size_t k = 0; k < image.texels.size(); k += 4) image.texels[k + 1] = image.texels[k + 2] = image.texels[k];
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(name, std::string("truncated or corrupt EXR (OpenEXR: ") + e.what() + ")");
  }
  return image;
}

}  // namespace

float srgbToLinear(float encoded) {
  // IEC 61966-2-1, in double so that 1 maps to exactly 1.
  const double c = encoded;
  return float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

RgbaImage decodeImage(const std::string& bytes, const std::string& name, ColorEncoding encoding) {
  const Format format = formatOf(bytes);
  if (format == Format::kUnknown)
    throw InputError(name, "not a PNG, JPEG, HDR or EXR image (" + firstBytes(bytes) + ")");
  RgbaImage image =
      format == Format::kExr ? decodeExrTexture(bytes, name) : decodeWithStb(bytes, format, name, encoding);
  if (format == Format::kExr || format == Format::kHdr) checkFloatTexels(image, format, name);
  return image;
}

}  // namespace lensfarm
