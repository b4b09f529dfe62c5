#pragma once
// Reading a whole file: one place for what scenes, assets, tokens, certificates and state files
// all need. (Writing goes through util/atomic_file.h.)
#include <filesystem>
#include <optional>
#include <string>

namespace lensfarm {

// The file's bytes, or nothing if it cannot be opened.
std::optional<std::string> readWholeFile(const std::filesystem::path& path);

// The file's bytes; throws InputError(where, "cannot read ...") if it cannot be opened.
std::string readWholeFileOrThrow(const std::filesystem::path& path, const std::string& where);

}  // namespace lensfarm
