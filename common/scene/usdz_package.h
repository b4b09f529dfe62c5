#pragma once
// A .usdz package (USD's "usdz file format specification": a zip archive, its entries stored
// uncompressed, the first USD layer the root), read with libzip (libzip-dev). The entries come
// back by name; scene/usd_import.h serves them to the layers as files relative to the package.
//
// Errors throw InputError naming the package: an archive libzip cannot open, an entry whose name
// leaves the package (an absolute path, "..") or that cannot be read, more than kMaxUsdzEntries
// entries or kMaxUsdzBytes of them, no USD layer inside.
#include <cstdint>
#include <map>
#include <string>

namespace lensfarm {

inline constexpr uint64_t kMaxUsdzEntries = 1u << 16;
inline constexpr uint64_t kMaxUsdzBytes = uint64_t(4) << 30;

struct UsdzPackage {
  std::string rootLayer;                     // the first .usda / .usdc / .usd entry
  std::map<std::string, std::string> files;  // every entry by its name in the archive
};

UsdzPackage readUsdz(const std::string& bytes, const std::string& shown);

}  // namespace lensfarm
