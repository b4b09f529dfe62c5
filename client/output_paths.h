#pragma once
// Output files named on the command line are checked before any work starts: a known extension
// and an existing directory, or one InputError naming the flag and the path.
#include <filesystem>
#include <string>
#include <vector>

namespace lensfarm::cli {

// `extensions` like {".exr", ".png"}; returns the path.
std::filesystem::path checkedOutput(const std::string& path, const std::vector<std::string>& extensions);

}  // namespace lensfarm::cli
