#include "common/film/image_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDoubleAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "common/film/exposure.h"
#include "common/util/atomic_file.h"
#include "common/util/error.h"

namespace lensfarm {

namespace fs = std::filesystem;

namespace {
constexpr const char* kPrefix = "lensfarm/";

// The beauty's R, G, B and every layer's channels, straight from the image's memory.
Imf::FrameBuffer frameBufferFor(Image& image) {
  Imf::FrameBuffer fb;
  const size_t xStride = 3 * sizeof(float), yStride = xStride * size_t(image.width);
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c)
    fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(image.rgb.data() + c), xStride, yStride));
  for (ImageLayer& layer : image.layers) {
    const size_t n = layer.channels.size(), lx = n * sizeof(float), ly = lx * size_t(image.width);
    for (size_t c = 0; c < n; ++c)
      fb.insert(layer.channelName(c), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(layer.values.data() + c), lx, ly));
  }
  return fb;
}
}  // namespace

namespace {
// Writes the EXR to `stream` straight from the image's pixels (no copy of the frame).
void writeExrTo(Imf::OStream& stream, const Image& image, const ImageMetadata& metadata, ExrCompression compression) {
  Imf::Header header(image.width, image.height);
  header.compression() = compression == ExrCompression::kZip ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION;
  for (const char* name : {"R", "G", "B"}) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  for (const ImageLayer& layer : image.layers) {
    if (layer.values.size() != size_t(image.width) * size_t(image.height) * layer.channels.size())
      throw std::logic_error("image layer " + layer.name + " does not match the image's size");
    for (size_t c = 0; c < layer.channels.size(); ++c)
      header.channels().insert(layer.channelName(c), Imf::Channel(Imf::FLOAT));
  }
  const std::string p = kPrefix;
  header.insert(p + "samplesPerPixel", Imf::StringAttribute(std::to_string(metadata.samplesPerPixel)));
  header.insert(p + "totalSamples", Imf::StringAttribute(std::to_string(metadata.totalSamples)));
  header.insert(p + "renderSeconds", Imf::DoubleAttribute(metadata.renderSeconds));
  header.insert(p + "sceneHash", Imf::StringAttribute(metadata.sceneHash));
  header.insert(p + "rendererVersion", Imf::StringAttribute(metadata.rendererVersion));
  for (const auto& [key, value] : metadata.extra) header.insert(p + key, Imf::StringAttribute(value));
  Imf::OutputFile file(stream, header);
  // OpenEXR wants non-const slices; an OutputFile only reads them.
  file.setFrameBuffer(frameBufferFor(const_cast<Image&>(image)));
  file.writePixels(image.height);
}  // the file is complete when OutputFile is destroyed
}  // namespace

namespace {
// An OStream into a std::string that the caller takes at the end (Imf::StdOSStream::str() would
// copy the whole encoded file).
class StringOStream final : public Imf::OStream {
 public:
  StringOStream() : Imf::OStream("(memory)") {}
  void write(const char c[], int n) override {
    const size_t end = position_ + size_t(n);
    if (end > bytes_.size()) bytes_.resize(end);
    std::memcpy(bytes_.data() + position_, c, size_t(n));
    position_ = end;
  }
  uint64_t tellp() override { return position_; }
  void seekp(uint64_t pos) override { position_ = size_t(pos); }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
  size_t position_ = 0;
};
}  // namespace

namespace {
// An OStream over a std::ostream (Imf::StdOFStream takes only an ofstream).
class StdOStreamAdapter final : public Imf::OStream {
 public:
  explicit StdOStreamAdapter(std::ostream& out) : Imf::OStream("(stream)"), out_(out) {}
  void write(const char c[], int n) override {
    if (!out_.write(c, n)) throw std::runtime_error("write failed");
  }
  uint64_t tellp() override { return uint64_t(out_.tellp()); }
  void seekp(uint64_t pos) override { out_.seekp(std::streamoff(pos)); }

 private:
  std::ostream& out_;
};
}  // namespace

void writeExr(std::ostream& out, const Image& image, const ImageMetadata& metadata, ExrCompression compression) {
  StdOStreamAdapter stream(out);
  writeExrTo(stream, image, metadata, compression);
  out.flush();
  if (!out) throw std::runtime_error("write failed");
}

std::string encodeExr(const Image& image, const ImageMetadata& metadata, ExrCompression compression) {
  StringOStream stream;
  writeExrTo(stream, image, metadata, compression);
  return stream.take();
}

namespace {
Image readExrStream(Imf::IStream& stream, ImageMetadata* metadata) {
  Imf::InputFile file(stream);
  const Imath::Box2i window = file.header().dataWindow();
  Image image;
  image.width = window.max.x - window.min.x + 1;
  image.height = window.max.y - window.min.y + 1;
  image.rgb.assign(size_t(image.width) * image.height * 3, 0.0f);
  // Every channel besides R, G, B joins the layer its name's prefix (before the last '.') names;
  // a channel of any pixel type is read as float.
  for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
    const std::string name = it.name();
    if (name == "R" || name == "G" || name == "B") continue;
    const size_t dot = name.rfind('.');
    const std::string layerName = dot == std::string::npos ? "" : name.substr(0, dot);
    ImageLayer* layer = nullptr;
    for (ImageLayer& l : image.layers)
      if (l.name == layerName) layer = &l;
    if (!layer) layer = &image.layers.emplace_back(ImageLayer{layerName, {}, {}});
    layer->channels.push_back(dot == std::string::npos ? name : name.substr(dot + 1));
  }
  // EXR lists channels alphabetically; a layer's colour and vector channels read back in their
  // usual order (R, G, B, A; X, Y, Z), any others after them, alphabetically.
  const auto rank = [](const std::string& c) {
    static const char* const kOrder[] = {"R", "G", "B", "A", "X", "Y", "Z"};
    for (size_t k = 0; k < std::size(kOrder); ++k)
      if (c == kOrder[k]) return k;
    return std::size(kOrder);
  };
  for (ImageLayer& layer : image.layers) {
    std::stable_sort(layer.channels.begin(), layer.channels.end(),
                     [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
    layer.values.assign(size_t(image.width) * size_t(image.height) * layer.channels.size(), 0.0f);
  }
  file.setFrameBuffer(frameBufferFor(image));
  file.readPixels(window.min.y, window.max.y);
  if (metadata) {
    *metadata = ImageMetadata{};
    for (auto it = file.header().begin(); it != file.header().end(); ++it) {
      const std::string name = it.name();
      if (name.rfind(kPrefix, 0) != 0) continue;
      const std::string key = name.substr(std::strlen(kPrefix));
      if (const auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&it.attribute())) {
        if (key == "renderSeconds") metadata->renderSeconds = d->value();
        continue;
      }
      const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
      if (!s) continue;
      if (key == "samplesPerPixel")
        metadata->samplesPerPixel = std::stoull(s->value());
      else if (key == "totalSamples")
        metadata->totalSamples = std::stoull(s->value());
      else if (key == "sceneHash")
        metadata->sceneHash = s->value();
      else if (key == "rendererVersion")
        metadata->rendererVersion = s->value();
      else
        metadata->extra[key] = s->value();
    }
  }
  return image;
}
}  // namespace

Image decodeExr(const std::string& bytes, ImageMetadata* metadata) {
  Imf::StdISStream stream;
  stream.str(bytes);
  return readExrStream(stream, metadata);
}

Image readExr(const fs::path& path, ImageMetadata* metadata) {
  try {
    Imf::StdIFStream stream(path.c_str());
    return readExrStream(stream, metadata);
  } catch (const std::exception& e) {
    throw InputError(path.string(), std::string("cannot read EXR: ") + e.what());
  }
}

namespace {
// libpng reports errors by longjmp: this function holds no C++ object whose destructor a jump
// would skip (the bytes are appended through `out`, owned by the caller). Returns libpng's
// message, or nullptr on success.
const char* deflatePng(png_structp png, png_infop info, const uint8_t* pixels, int width, int height,
                       std::string* out) {
  if (setjmp(png_jmpbuf(png))) return "PNG encoding failed";
  png_set_write_fn(
      png, out,
      [](png_structp p, png_bytep data, png_size_t n) {
        try {
          static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), n);
        } catch (const std::bad_alloc&) {
          png_error(p, "out of memory");  // no C++ exception through libpng's C frames
        }
      },
      nullptr);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // Lossless whatever is chosen here; only time and size change (header comment).
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_set_compression_level(png, 1);
  png_set_compression_strategy(png, Z_RLE);
  png_write_info(png, info);
  const size_t stride = 3 * size_t(width);
  for (int y = 0; y < height; ++y) png_write_row(png, pixels + size_t(y) * stride);
  png_write_end(png, nullptr);
  return nullptr;
}
}  // namespace

std::string encodePng(const Image& image, const ExposureSettings& exposure) {
  const std::vector<uint8_t> pixels = exposeToSrgb8(image, exposure);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::bad_alloc();
  }
  std::string bytes;
  bytes.reserve(pixels.size() + pixels.size() / 64 + 1024);  // a noisy image hardly shrinks
  const char* error = deflatePng(png, info, pixels.data(), image.width, image.height, &bytes);
  png_destroy_write_struct(&png, &info);
  if (error) throw std::runtime_error(error);
  return bytes;
}

void writeBytesAtomically(const fs::path& path, const std::string& bytes) {
  writeFileAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.close();
    if (!out) throw std::runtime_error("write failed");
  });
}

void writeExr(const fs::path& path, const Image& image, const ImageMetadata& metadata, ExrCompression compression) {
  // Straight into the file: no encoded copy of the frame in memory.
  writeFileAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot create " + tmp.string());
    Imf::StdOFStream stream(out, tmp.c_str());
    writeExrTo(stream, image, metadata, compression);
    out.close();
    if (!out) throw std::runtime_error("write failed");
  });
}

void writePng(const fs::path& path, const Image& image, const ExposureSettings& exposure) {
  writeBytesAtomically(path, encodePng(image, exposure));
}

void writeImageFile(const fs::path& path, const Image& image, const ImageMetadata& metadata,
                    const ExposureSettings& exposure, ExrCompression compression) {
  const std::string ext = path.extension().string();
  if (ext == ".exr")
    writeExr(path, image, metadata, compression);
  else if (ext == ".png")
    writePng(path, image, exposure);
  else
    throw InputError(path.string(), "unknown image format \"" + ext + "\" (expected .exr or .png)");
}

}  // namespace lensfarm
