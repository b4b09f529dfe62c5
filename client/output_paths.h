#pragma once
// Output files named on the command line are checked before any work starts: a known extension
// and an existing directory, or one InputError naming the flag and the path.
#include <filesystem>
#include <string>
#include <vector>

namespace lensfarm::cli {

// `extensions` like {".exr", ".png"}; returns the path.
std::filesystem::path checkedOutput(const std::string& path, const std::vector<std::string>& extensions);

// What `render` writes without -o: SCENE.exr and SCENE.png in the current directory, named after
// the scene file's stem ("scenes/cornell-seed.json" gives "cornell-seed.exr", "cornell-seed.png").
std::vector<std::string> defaultOutputs(const std::string& scene);

}  // namespace lensfarm::cli
