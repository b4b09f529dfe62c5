#include "common/scene/usdz_package.h"

#include <zip.h>

#include <filesystem>
#include <memory>

#include "common/util/error.h"

namespace lensfarm {

namespace {

struct ArchiveCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
struct FileCloser {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};

bool isLayer(const std::string& name) {
  const std::string ext = std::filesystem::path(name).extension().string();
  return ext == ".usda" || ext == ".usdc" || ext == ".usd";
}

}  // namespace

UsdzPackage readUsdz(const std::string& bytes, const std::string& shown) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
  if (!source) throw InputError(shown, std::string("cannot read the USDZ package: ") + zip_error_strerror(&error));
  std::unique_ptr<zip_t, ArchiveCloser> archive(zip_open_from_source(source, ZIP_RDONLY, &error));
  if (!archive) {
    zip_source_free(source);
    const std::string why = zip_error_strerror(&error);
    zip_error_fini(&error);
    throw InputError(shown, "is not a readable USDZ package (zip): " + why);
  }
  const zip_int64_t count = zip_get_num_entries(archive.get(), 0);
  if (count < 0 || uint64_t(count) > kMaxUsdzEntries)
    throw InputError(shown, "has " + std::to_string(count) + " entries; at most " + std::to_string(kMaxUsdzEntries));
  UsdzPackage package;
  uint64_t total = 0;
  for (zip_int64_t i = 0; i < count; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(archive.get(), zip_uint64_t(i), 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME) ||
        !(st.valid & ZIP_STAT_SIZE))
      throw InputError(shown, "entry " + std::to_string(i) + " cannot be read");
    const std::string name = st.name;
    if (!name.empty() && name.back() == '/') continue;  // a folder
    const std::filesystem::path normal = std::filesystem::path(name).lexically_normal();
    if (name.empty() || normal.is_absolute() || *normal.begin() == "..")
      throw InputError(shown, "entry \"" + name + "\" leaves the package");
    total += st.size;
    if (total > kMaxUsdzBytes)
      throw InputError(shown, "holds more than " + std::to_string(kMaxUsdzBytes >> 30) + " GiB uncompressed");
    std::unique_ptr<zip_file_t, FileCloser> file(zip_fopen_index(archive.get(), zip_uint64_t(i), 0));
    if (!file) throw InputError(shown, "entry \"" + name + "\" cannot be opened: " + zip_strerror(archive.get()));
    std::string content(size_t(st.size), '\0');
    const zip_int64_t got = content.empty() ? 0 : zip_fread(file.get(), content.data(), st.size);
    if (got < 0 || uint64_t(got) != st.size) throw InputError(shown, "entry \"" + name + "\" is truncated");
    if (package.rootLayer.empty() && isLayer(name)) package.rootLayer = normal.generic_string();
    package.files[normal.generic_string()] = std::move(content);
  }
  if (package.rootLayer.empty()) throw InputError(shown, "holds no USD layer (.usda, .usdc or .usd)");
  return package;
}

}  // namespace lensfarm
