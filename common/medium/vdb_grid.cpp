#include "common/medium/vdb_grid.h"

#include <dlfcn.h>

#include <filesystem>
#include <string>
#include <vector>

#include "common/util/error.h"

namespace lensfarm {

namespace {

// Where the module may be: beside the running binary as installed (LENSFARM_OPENVDB_MODULE_RELATIVE,
// from <prefix>/<bindir> to <prefix>/<libdir>/lensfarm), then where this build made it.
std::vector<std::filesystem::path> moduleCandidates() {
  std::vector<std::filesystem::path> paths;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) paths.push_back((self.parent_path() / LENSFARM_OPENVDB_MODULE_RELATIVE).lexically_normal());
  paths.emplace_back(LENSFARM_OPENVDB_MODULE_BUILT);
  return paths;
}

struct Module {
  VdbReadFunction read = nullptr;
  std::string why;  // when read is null
};

Module loadModule() {
  std::string tried;
  for (const std::filesystem::path& path : moduleCandidates()) {
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      tried += std::string(tried.empty() ? "" : "; ") + ::dlerror();
      continue;
    }
    if (auto read = reinterpret_cast<VdbReadFunction>(::dlsym(handle, kVdbReadSymbol)))
      return {read, ""};  // kept loaded for the process's life
    tried += path.string() + " has no " + kVdbReadSymbol;
    ::dlclose(handle);
  }
  return {nullptr, "this installation cannot read OpenVDB files: its reader module is missing (" + tried + ")"};
}

// Loaded once, by the first scene that names a .vdb (a function-local static: thread-safe).
const Module& openModule() {
  static const Module module = loadModule();
  return module;
}

}  // namespace

DenseGrid readVdbGrid(const std::string& content, const std::string& gridName, const std::string& shown,
                      const std::string& file, const std::string& field) {
  const Module& module = openModule();
  if (!module.read) throw InputError(file, field + ": " + module.why);
  DenseGrid grid;
  std::string error;
  if (!module.read(content, gridName, shown, grid, error)) throw InputError(file, field + ": " + error);
  return grid;
}

}  // namespace lensfarm
