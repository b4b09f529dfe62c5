#pragma once
// Writing output files so that a reader never sees a partial one: write to a temporary file in
// the same directory, fsync, then rename over the target (atomic on POSIX file systems).
#include <filesystem>
#include <functional>

namespace lensfarm {

// Calls write(tmpPath) and then publishes tmpPath as `path`. If write throws, the temporary file
// is removed and `path` is untouched. Throws InputError naming `path` if it cannot be written.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tmpPath)>& write);

}  // namespace lensfarm
